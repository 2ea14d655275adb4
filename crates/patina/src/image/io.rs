//! Codecs: PNG / JPEG (8 and 16 bit; gray, gray+alpha, RGB, RGBA) and
//! OpenEXR (any channels, f16/f32/u32 read as f32). Buffers live in
//! [`Image`]; this module only converts. Every write goes to a temporary file
//! in the destination folder and is renamed into place when complete, so a
//! failed or interrupted run never leaves a half-written file.
//!
//! Values: 8/16-bit files map to [0, 1] as stored (sRGB-encoded for
//! ordinary photos; see [`super::color`] to linearise). EXR values are kept
//! as they are.

use super::{ChannelGroup, Image, MAX_SIDE};
use crate::error::{Error, Result};
use std::io::{Cursor, Write};
use std::path::{Path, PathBuf};

/// Bits per channel for PNG output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum BitDepth {
    Eight,
    Sixteen,
}

/// Largest sample magnitude accepted. Colours, material parameters and
/// their polynomial coefficients are all far below it (f16 EXR tops out at
/// 65504); beyond it, squared patch distances summed over a patch overflow
/// f32 and every method's answer would be meaningless.
pub const MAX_MAGNITUDE: f32 = 1e6;

const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// How strictly files are read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Set NaN and infinite samples (possible only in EXR files) to 0
    /// instead of refusing the file; [`Loaded::nonfinite`] counts them.
    pub allow_nonfinite: bool,
}

/// A decoded file and what was changed to accept it.
#[derive(Clone, Debug)]
pub struct Loaded {
    pub image: Image,
    /// Non-finite samples set to 0 (only with [`LoadOptions::allow_nonfinite`]).
    pub nonfinite: usize,
}

/// The file formats patina reads, recognised from their content.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputFormat {
    Png,
    Jpeg,
    Gif,
    Exr,
}

/// What a file's header declares, read before any pixel is decoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    pub format: InputFormat,
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    /// Bytes per sample of the decoder's own buffer.
    pub bytes_per_sample: usize,
}

impl Header {
    /// Bytes decoding needs: the decoder's buffer, its f32 copy, and the
    /// engine's working set at this size (every command works on its
    /// inputs at least at their own size).
    pub fn decode_bytes(&self) -> u128 {
        let samples = (self.width as u128) * (self.height as u128) * self.channels as u128;
        samples * (self.bytes_per_sample as u128 + 4) + super::budget::working_set(self.width, self.height, self.channels)
    }
}

/// Load an image file strictly; the format is recognised from its content.
/// See [`decode_with`].
pub fn load(path: impl AsRef<Path>) -> Result<Image> {
    load_with(path, LoadOptions::default()).map(|l| l.image)
}

/// Load an image file with `options`; see [`decode_with`].
pub fn load_with(path: impl AsRef<Path>, options: LoadOptions) -> Result<Loaded> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| Error::Read { path: path.into(), source })?;
    decode_with(&bytes, path, options)
}

/// Decode an in-memory file strictly; `path` only names it in errors.
pub fn decode(bytes: &[u8], path: &Path) -> Result<Image> {
    decode_with(bytes, path, LoadOptions::default()).map(|l| l.image)
}

/// Decode an in-memory file; `path` only names it in errors.
///
/// The one input gate: the header is read first and the size checked
/// against [`MAX_SIDE`] and the memory budget ([`super::budget`]) before any
/// pixel buffer is allocated. Decoding is strict: a PNG whose CRC or zlib
/// checksum fails or that ends before `IEND`, a JPEG without its end marker
/// after the last scan, non-finite samples and samples beyond
/// [`MAX_MAGNITUDE`] are errors. A JPEG's EXIF
/// orientation is applied, so phone photos (and masks painted on them) load
/// upright.
pub fn decode_with(bytes: &[u8], path: &Path, options: LoadOptions) -> Result<Loaded> {
    let bad = |reason: String| Error::Decode { path: path.into(), reason };
    let header = read_header(bytes, path)?;
    check_side(header.width, header.height).map_err(|e| bad(e.to_string()))?;
    super::budget::check(
        || format!("{} ({}x{}, {} channels)", path.display(), header.width, header.height, header.channels),
        header.decode_bytes(),
    )?;
    let mut image = match header.format {
        InputFormat::Exr => decode_exr(bytes),
        InputFormat::Png => decode_png(bytes),
        InputFormat::Jpeg => decode_jpeg(bytes),
        InputFormat::Gif => decode_gif(bytes),
    }
    .map_err(|e| bad(e.to_string()))?;
    if image.width() * image.height() * image.channels() > header.width * header.height * header.channels.max(4) {
        return Err(bad("the decoded image is larger than its header declares".into()));
    }
    let nonfinite = image.data().iter().filter(|v| !v.is_finite()).count();
    if nonfinite > 0 {
        if !options.allow_nonfinite {
            return Err(bad(format!("{nonfinite} samples are NaN or infinite (--allow-nonfinite sets them to 0)")));
        }
        image.data_mut().iter_mut().filter(|v| !v.is_finite()).for_each(|v| *v = 0.0);
    }
    if let Some(v) = image.data().iter().copied().find(|v| v.abs() > MAX_MAGNITUDE) {
        return Err(bad(format!("a sample is {v:e}, beyond the +/-{MAX_MAGNITUDE:e} patina accepts")));
    }
    Ok(Loaded { image, nonfinite })
}

/// Read the size and channels a file declares, without decoding pixels.
pub fn read_header(bytes: &[u8], path: &Path) -> Result<Header> {
    let bad = |reason: String| Error::Decode { path: path.into(), reason };
    if bytes.starts_with(&EXR_MAGIC) {
        let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(|e| bad(e.to_string()))?;
        let h = meta.headers.iter().find(|h| !h.deep).ok_or_else(|| bad("the file holds only deep data".into()))?;
        let bytes_per_sample =
            h.channels.list.iter().map(|c| if c.sample_type == exr::meta::attribute::SampleType::F16 { 2 } else { 4 }).max().unwrap_or(4);
        return Ok(Header {
            format: InputFormat::Exr,
            width: h.layer_size.width(),
            height: h.layer_size.height(),
            channels: h.channels.list.len().max(1),
            bytes_per_sample,
        });
    }
    let reader = image::ImageReader::new(Cursor::new(bytes)).with_guessed_format().map_err(|e| bad(e.to_string()))?;
    let format = match reader.format() {
        Some(image::ImageFormat::Png) => InputFormat::Png,
        Some(image::ImageFormat::Jpeg) => InputFormat::Jpeg,
        Some(image::ImageFormat::Gif) => InputFormat::Gif,
        _ => return Err(bad("unknown file format; expected PNG, JPEG, GIF or OpenEXR".into())),
    };
    use image::ImageDecoder;
    let decoder = reader.into_decoder().map_err(|e| bad(e.to_string()))?;
    let (w, h) = decoder.dimensions();
    let colour = decoder.color_type();
    let channels = usize::from(colour.channel_count());
    Ok(Header {
        format,
        width: w as usize,
        height: h as usize,
        channels,
        bytes_per_sample: usize::from(colour.bytes_per_pixel()) / channels.max(1),
    })
}

fn check_side(w: usize, h: usize) -> Result<()> {
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
        return Err(Error::invalid(format!("size {w}x{h} is outside 1..={MAX_SIDE} per side")));
    }
    Ok(())
}

type DecodeResult = std::result::Result<Image, Box<dyn std::error::Error>>;

/// PNG through the `png` crate with every checksum verified and the file
/// read to its `IEND` (the `image` crate skips the zlib checksum).
fn decode_png(bytes: &[u8]) -> DecodeResult {
    let mut decoder = png::Decoder::new(Cursor::new(bytes));
    decoder.ignore_checksums(false);
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info()?;
    let mut buf = vec![0u8; reader.output_buffer_size().ok_or("the image is too large")?];
    let frame = reader.next_frame(&mut buf)?;
    let orientation = reader.info().exif_metadata.as_deref().and_then(image::metadata::Orientation::from_exif_chunk);
    reader.finish()?;
    buf.truncate(frame.buffer_size());
    let (w, h) = (frame.width, frame.height);
    let channels = frame.color_type.samples();
    let data: Vec<f32> = match frame.bit_depth {
        png::BitDepth::Sixteen => buf.chunks_exact(2).map(|b| u16::from_be_bytes([b[0], b[1]]) as f32 / 65535.0).collect(),
        png::BitDepth::Eight => buf.iter().map(|&b| b as f32 / 255.0).collect(),
        other => return Err(format!("unexpected bit depth {other:?} after expansion").into()),
    };
    let img = Image::from_data(w as usize, h as usize, channels, data)?;
    Ok(match orientation {
        Some(o) => oriented(img, o)?,
        None => img,
    })
}

/// JPEG through the `image` crate, refusing a file cut short (no end-of-image
/// marker after the last scan; the decoder would fill the rest with grey)
/// and applying the EXIF orientation.
fn decode_jpeg(bytes: &[u8]) -> DecodeResult {
    let last_scan = bytes.windows(2).rposition(|m| m == [0xFF, 0xDA]).ok_or("the file has no image scan")?;
    if !bytes[last_scan..].windows(2).any(|m| m == [0xFF, 0xD9]) {
        return Err("the file is truncated (no end-of-image marker after the last scan)".into());
    }
    use image::ImageDecoder;
    let mut decoder = image::codecs::jpeg::JpegDecoder::new(Cursor::new(bytes))?;
    let orientation = decoder.orientation()?;
    let mut dynamic = image::DynamicImage::from_decoder(decoder)?;
    dynamic.apply_orientation(orientation);
    Ok(from_dynamic(dynamic)?)
}

/// A GIF's first frame.
fn decode_gif(bytes: &[u8]) -> DecodeResult {
    let mut reader = image::ImageReader::new(Cursor::new(bytes)).with_guessed_format()?;
    reader.no_limits();
    Ok(from_dynamic(reader.decode()?)?)
}

/// `img` turned upright by an EXIF orientation.
fn oriented(img: Image, o: image::metadata::Orientation) -> Result<Image> {
    use image::metadata::Orientation as O;
    if o == O::NoTransforms {
        return Ok(img);
    }
    let (w, h) = img.size();
    let swap = matches!(o, O::Rotate90 | O::Rotate270 | O::Rotate90FlipH | O::Rotate270FlipH);
    let (ow, oh) = if swap { (h, w) } else { (w, h) };
    let mut out = Image::from_fn(ow, oh, img.channels(), |x, y, p| {
        // Source pixel of output (x, y) for each of the eight orientations.
        let (sx, sy) = match o {
            O::NoTransforms => (x, y),
            O::FlipHorizontal => (w - 1 - x, y),
            O::Rotate180 => (w - 1 - x, h - 1 - y),
            O::FlipVertical => (x, h - 1 - y),
            O::Rotate90FlipH => (y, x),
            O::Rotate90 => (y, h - 1 - x),
            O::Rotate270FlipH => (w - 1 - y, h - 1 - x),
            O::Rotate270 => (w - 1 - y, x),
        };
        p.copy_from_slice(img.pixel(sx, sy));
    });
    out.set_groups(img.groups().to_vec())?;
    Ok(out)
}

fn from_dynamic(d: image::DynamicImage) -> Result<Image> {
    use image::DynamicImage as D;
    let (w, h) = (d.width() as usize, d.height() as usize);
    let n8 = |v: Vec<u8>| v.into_iter().map(|b| b as f32 / 255.0).collect::<Vec<f32>>();
    let n16 = |v: Vec<u16>| v.into_iter().map(|b| b as f32 / 65535.0).collect::<Vec<f32>>();
    let (channels, data) = match d {
        D::ImageLuma8(b) => (1, n8(b.into_raw())),
        D::ImageLumaA8(b) => (2, n8(b.into_raw())),
        D::ImageRgb8(b) => (3, n8(b.into_raw())),
        D::ImageRgba8(b) => (4, n8(b.into_raw())),
        D::ImageLuma16(b) => (1, n16(b.into_raw())),
        D::ImageLumaA16(b) => (2, n16(b.into_raw())),
        D::ImageRgb16(b) => (3, n16(b.into_raw())),
        D::ImageRgba16(b) => (4, n16(b.into_raw())),
        D::ImageRgb32F(b) => (3, b.into_raw()),
        D::ImageRgba32F(b) => (4, b.into_raw()),
        other => (4, other.to_rgba32f().into_raw()),
    };
    Image::from_data(w, h, channels, data)
}

/// EXR channel order: R, G, B, A first (in that order), then the others by name.
fn exr_rank(name: &str) -> (usize, String) {
    let rank = ["R", "G", "B", "A"].iter().position(|&c| c == name).unwrap_or(4);
    (rank, name.to_string())
}

fn decode_exr(bytes: &[u8]) -> DecodeResult {
    use exr::prelude::*;
    let img = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))?;
    let layer = img.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    let mut chans: Vec<(String, Vec<f32>)> = layer
        .channel_data
        .list
        .into_iter()
        .map(|c| {
            let values: Vec<f32> = match c.sample_data {
                FlatSamples::F16(v) => v.into_iter().map(f16::to_f32).collect(),
                FlatSamples::F32(v) => v,
                FlatSamples::U32(v) => v.into_iter().map(|u| u as f32).collect(),
            };
            (c.name.to_string(), values)
        })
        .collect();
    chans.sort_by_key(|(n, _)| exr_rank(n));
    let n = chans.len();
    if n == 0 {
        return Err("the file has no channels".into());
    }
    let mut data = vec![0f32; w * h * n];
    for (c, (_, values)) in chans.iter().enumerate() {
        for (p, v) in values.iter().enumerate() {
            data[p * n + c] = *v;
        }
    }
    let mut out = super::Image::from_data(w, h, n, data)?;
    let names: Vec<&str> = chans.iter().map(|(n, _)| n.as_str()).collect();
    out.set_groups(exr_groups(&names))?;
    Ok(out)
}

/// Group EXR channels: R,G,B -> `rgb`, A -> `alpha`, Y -> `gray`, others by name.
fn exr_groups(names: &[&str]) -> Vec<ChannelGroup> {
    let mut groups = Vec::new();
    let mut c = 0;
    while c < names.len() {
        if names[c..].starts_with(&["R", "G", "B"]) {
            groups.push(ChannelGroup { name: "rgb".into(), channels: c..c + 3 });
            c += 3;
            continue;
        }
        let name = match names[c] {
            "A" => "alpha",
            "Y" => "gray",
            other => other,
        };
        groups.push(ChannelGroup { name: name.to_string(), channels: c..c + 1 });
        c += 1;
    }
    groups
}

/// EXR channel names for an image's channels, from its groups.
fn exr_channel_names(img: &Image) -> Vec<String> {
    let mut names = vec![String::new(); img.channels()];
    for g in img.groups() {
        let len = g.channels.len();
        for (i, c) in g.channels.clone().enumerate() {
            names[c] = match (g.name.as_str(), len) {
                ("rgb", 3) => ["R", "G", "B"][i].to_string(),
                ("alpha", 1) => "A".to_string(),
                ("gray", 1) => "Y".to_string(),
                (name, 1) => name.to_string(),
                (name, _) => format!("{name}.{i}"),
            };
        }
    }
    for (c, n) in names.iter_mut().enumerate() {
        if n.is_empty() {
            *n = format!("channel{c}");
        }
    }
    names
}

/// Write `bytes` produced by `fill` to `path` atomically: a temporary file in
/// the same folder, renamed over `path` only once complete.
pub fn write_atomic(path: &Path, fill: impl FnOnce(&mut Vec<u8>) -> Result<()>) -> Result<()> {
    let werr = |source| Error::Write { path: path.into(), source };
    let mut bytes = Vec::new();
    fill(&mut bytes)?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path.file_name().ok_or_else(|| Error::invalid(format!("{} is not a file path", path.display())))?;
    let tmp = dir.join(format!(".{}.{}.tmp", name.to_string_lossy(), std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(&bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(werr(e));
    }
    Ok(())
}

/// Pixels sampled (over all frames) to train an animation's palette.
const PALETTE_SAMPLES: usize = 1 << 20;

/// Save `frames` (one size; grey, RGB or with alpha, values in [0, 1]) as
/// an animated GIF that loops forever, each frame shown `delay_ms`.
/// One palette serves every frame (NeuQuant, trained on pixels sampled
/// evenly from all of them), so colours that stay put do not shimmer from
/// frame to frame as they would with a palette per frame. Pixels with
/// alpha below one half are transparent.
pub fn save_gif(frames: &[&Image], path: impl AsRef<Path>, delay_ms: u32) -> Result<()> {
    use rayon::prelude::*;
    let path = path.as_ref();
    let first = frames.first().ok_or_else(|| Error::invalid("an animation needs at least one frame"))?;
    if frames.iter().any(|f| f.size() != first.size()) {
        return Err(Error::invalid("animation frames differ in size"));
    }
    let (w, h) = (first.width(), first.height());
    if w > usize::from(u16::MAX) || h > usize::from(u16::MAX) {
        return Err(Error::invalid(format!("a GIF cannot be {w}x{h} (at most 65535 per side)")));
    }
    let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    let to_rgba = |p: &[f32]| -> [u8; 4] {
        match p.len() {
            1 => [q(p[0]), q(p[0]), q(p[0]), 255],
            2 => [q(p[0]), q(p[0]), q(p[0]), q(p[1])],
            3 => [q(p[0]), q(p[1]), q(p[2]), 255],
            _ => [q(p[0]), q(p[1]), q(p[2]), q(p[3])],
        }
    };
    let rgba = |f: &Image| -> Vec<u8> { f.data().chunks_exact(f.channels()).flat_map(to_rgba).collect() };
    // Train on every step-th opaque pixel of every frame (converting only those).
    let total = w * h * frames.len();
    let step = total.div_ceil(PALETTE_SAMPLES).max(1);
    let mut training = Vec::with_capacity(4 * total.div_ceil(step));
    let n = first.channels();
    for k in (0..total).step_by(step) {
        let (f, i) = (k / (w * h), k % (w * h));
        let p = to_rgba(&frames[f].data()[i * n..(i + 1) * n]);
        if p[3] >= 128 {
            training.extend_from_slice(&[p[0], p[1], p[2], 255]);
        }
    }
    if training.is_empty() {
        training.extend_from_slice(&[0, 0, 0, 255]);
    }
    // Index 255 is kept for transparency.
    let quant = color_quant::NeuQuant::new(10, 255, &training);
    let mut palette = quant.color_map_rgb();
    palette.resize(256 * 3, 0);
    let delay = u16::try_from(delay_ms.div_ceil(10)).unwrap_or(u16::MAX);
    let encoded: Vec<gif::Frame<'static>> = frames
        .par_iter()
        .map(|f| {
            let px = rgba(f);
            let transparent = px.chunks_exact(4).any(|p| p[3] < 128);
            let indices: Vec<u8> =
                px.chunks_exact(4).map(|p| if p[3] < 128 { 255 } else { quant.index_of(&[p[0], p[1], p[2], 255]) as u8 }).collect();
            let mut frame = gif::Frame::from_palette_pixels(w as u16, h as u16, indices, Vec::new(), transparent.then_some(255));
            frame.palette = None; // the global palette
            frame.delay = delay;
            frame
        })
        .collect();
    write_atomic(path, |buf| {
        let gif_err = |e: gif::EncodingError| Error::Internal(format!("gif: {e}"));
        let mut enc = gif::Encoder::new(&mut *buf, w as u16, h as u16, &palette).map_err(gif_err)?;
        enc.set_repeat(gif::Repeat::Infinite).map_err(gif_err)?;
        for frame in &encoded {
            enc.write_frame(frame).map_err(gif_err)?;
        }
        Ok(())
    })
}

/// Save as PNG. 1, 2, 3 or 4 channels (gray, gray+alpha, RGB, RGBA); values
/// are clamped to [0, 1].
pub fn save_png(img: &Image, path: impl AsRef<Path>, depth: BitDepth) -> Result<()> {
    let path = path.as_ref();
    write_atomic(path, |buf| encode_png(img, depth, buf))
}

/// Encode as PNG into `out` (see [`save_png`]).
pub fn encode_png(img: &Image, depth: BitDepth, out: &mut Vec<u8>) -> Result<()> {
    use image::{ExtendedColorType as E, ImageEncoder};
    let color = match (img.channels(), depth) {
        (1, BitDepth::Eight) => E::L8,
        (2, BitDepth::Eight) => E::La8,
        (3, BitDepth::Eight) => E::Rgb8,
        (4, BitDepth::Eight) => E::Rgba8,
        (1, BitDepth::Sixteen) => E::L16,
        (2, BitDepth::Sixteen) => E::La16,
        (3, BitDepth::Sixteen) => E::Rgb16,
        (4, BitDepth::Sixteen) => E::Rgba16,
        (n, _) => return Err(Error::invalid(format!("PNG holds 1 to 4 channels, this image has {n}; save it as EXR"))),
    };
    let bytes: Vec<u8> = match depth {
        BitDepth::Eight => img.data().iter().map(|&v| (v.clamp(0.0, 1.0) * 255.0).round() as u8).collect(),
        BitDepth::Sixteen => img.data().iter().flat_map(|&v| ((v.clamp(0.0, 1.0) * 65535.0).round() as u16).to_ne_bytes()).collect(),
    };
    image::codecs::png::PngEncoder::new(out)
        .write_image(&bytes, img.width() as u32, img.height() as u32, color)
        .map_err(|e| Error::Internal(format!("PNG encoding failed: {e}")))
}

/// Save as OpenEXR with every channel as f32, named from the channel groups.
pub fn save_exr(img: &Image, path: impl AsRef<Path>) -> Result<()> {
    use exr::prelude::{AnyChannel, AnyChannels, Encoding, FlatSamples, Layer, LayerAttributes, LineOrder, SmallVec, WritableImage};
    let path = path.as_ref();
    write_atomic(path, |buf| {
        let names = exr_channel_names(img);
        let n = img.channels();
        let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = names
            .iter()
            .enumerate()
            .map(|(c, name)| {
                let values: Vec<f32> = img.data().iter().skip(c).step_by(n).copied().collect();
                AnyChannel::new(name.as_str(), FlatSamples::F32(values))
            })
            .collect();
        // Increasing line order: chunks compressed in parallel are still
        // written in order, so the same image always gives the same bytes.
        let encoding = Encoding { line_order: LineOrder::Increasing, ..Encoding::FAST_LOSSLESS };
        let layer = Layer::new((img.width(), img.height()), LayerAttributes::named("patina"), encoding, AnyChannels::sort(list));
        exr::prelude::Image::from_layer(layer)
            .write()
            .to_buffered(Cursor::new(buf))
            .map_err(|e| Error::Internal(format!("EXR encoding failed: {e}")))
    })
}

/// Output formats [`save`] picks by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Png,
    Exr,
}

/// The format for writing an image of `channels` channels to `path`, or why
/// it cannot be written there. Check before long work, not after.
pub fn output_format(path: &Path, channels: usize) -> Result<Format> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("exr") => Ok(Format::Exr),
        Some("png") if channels <= 4 => Ok(Format::Png),
        Some("png") => {
            Err(Error::invalid(format!("{}: PNG holds at most 4 channels, this image has {channels}; use .exr", path.display())))
        }
        _ => Err(Error::invalid(format!("{}: output must end in .png or .exr", path.display()))),
    }
}

/// Save by extension: `.exr` as OpenEXR, `.png` as PNG of `depth` bits.
pub fn save(img: &Image, path: impl AsRef<Path>, depth: BitDepth) -> Result<()> {
    let path = path.as_ref();
    match output_format(path, img.channels())? {
        Format::Exr => save_exr(img, path),
        Format::Png => save_png(img, path, depth),
    }
}

#[cfg(test)]
mod tests {

    #[test]
    fn exr_bytes_are_the_same_every_time() {
        // Many chunks, compressed in parallel, must still land in one order.
        let img = Image::from_fn(256, 512, 3, |x, y, p| {
            for (c, v) in p.iter_mut().enumerate() {
                *v = ((x * 7919 + y * 104729 + c * 31) % 1009) as f32 / 1009.0;
            }
        });
        let dir = std::env::temp_dir().join(format!("patina-exr-bytes-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let first = dir.join("a.exr");
        save_exr(&img, &first).unwrap();
        let want = std::fs::read(&first).unwrap();
        for i in 0..6 {
            let p = dir.join(format!("b{i}.exr"));
            save_exr(&img, &p).unwrap();
            assert_eq!(std::fs::read(&p).unwrap(), want, "write {i} differs");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
    use super::*;

    fn gradient(c: usize) -> Image {
        Image::from_fn(7, 5, c, |x, y, p| {
            for (i, v) in p.iter_mut().enumerate() {
                *v = ((x * 5 + y * 3 + i * 17) % 31) as f32 / 30.0;
            }
        })
    }

    fn temp_dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("patina-io-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn an_animation_shares_one_palette_so_still_pixels_keep_their_colour() {
        // The left half is a still colour ramp; the right half changes hue
        // from frame to frame, which would move a per-frame palette.
        let frames: Vec<Image> = (0..6)
            .map(|t| {
                Image::from_fn(64, 32, 3, |x, y, p| {
                    if x < 32 {
                        p.copy_from_slice(&[x as f32 / 31.0, y as f32 / 31.0, 0.5]);
                    } else {
                        let a = t as f32 / 5.0;
                        p.copy_from_slice(&[a, 1.0 - a, (x as f32 / 63.0 + a) % 1.0]);
                    }
                })
            })
            .collect();
        let dir = temp_dir("gif");
        let path = dir.join("a.gif");
        save_gif(&frames.iter().collect::<Vec<_>>(), &path, 50).unwrap();
        let back = crate::image::sequence::load_sequence(&path).unwrap().frames;
        assert_eq!(back.len(), 6);
        for f in &back[1..] {
            for y in 0..32 {
                for x in 0..32 {
                    assert_eq!(f.pixel(x, y), back[0].pixel(x, y), "still pixel ({x}, {y}) changed colour");
                }
            }
        }
        // And the palette still represents the colours closely.
        let err = back[3].data().iter().zip(frames[3].data()).map(|(a, b)| (a - b).abs()).sum::<f32>() / back[3].data().len() as f32;
        assert!(err < 0.03, "mean error {err}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn png_round_trips_every_layout_at_both_depths() {
        let dir = temp_dir("png");
        for c in 1..=4 {
            for (depth, step) in [(BitDepth::Eight, 255.0), (BitDepth::Sixteen, 65535.0)] {
                let img = gradient(c);
                let p = dir.join(format!("{c}-{step}.png"));
                save_png(&img, &p, depth).unwrap();
                let back = load(&p).unwrap();
                assert_eq!(back.channels(), c, "alpha and gray must survive");
                for (a, b) in img.data().iter().zip(back.data()) {
                    assert!((a - b).abs() <= 0.5 / step + 1e-6);
                }
            }
        }
        assert!(matches!(save_png(&gradient(5), dir.join("x.png"), BitDepth::Eight), Err(Error::InvalidInput(_))));
        assert!(!dir.join("x.png").exists());
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn exr_round_trips_many_channels_exactly() {
        let dir = temp_dir("exr");
        let mut img = gradient(9).map(|v| v * 40.0 - 3.0);
        img.set_groups(vec![
            ChannelGroup { name: "rgb".into(), channels: 0..3 },
            ChannelGroup { name: "rough".into(), channels: 3..4 },
            ChannelGroup { name: "coef".into(), channels: 4..9 },
        ])
        .unwrap();
        let p = dir.join("m.exr");
        save_exr(&img, &p).unwrap();
        let back = load(&p).unwrap();
        assert_eq!(back.channels(), 9);
        assert_eq!(back.group("rgb"), Some(0..3));
        // R,G,B come back first and exact; the other channels keep their values (sorted by name).
        assert_eq!(back.select_channels(0..3), img.select_channels(0..3));
        let mut a: Vec<u32> = img.data().iter().map(|v| v.to_bits()).collect();
        let mut b: Vec<u32> = back.data().iter().map(|v| v.to_bits()).collect();
        a.sort();
        b.sort();
        assert_eq!(a, b);
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn corrupt_and_missing_files_are_clear_errors() {
        let dir = temp_dir("bad");
        let p = dir.join("bad.png");
        std::fs::write(&p, b"\x89PNG\r\n\x1a\nthis is not a png").unwrap();
        assert!(matches!(load(&p), Err(Error::Decode { .. })));
        std::fs::write(&p, b"hello").unwrap();
        assert!(matches!(load(&p), Err(Error::Decode { .. })));
        assert!(matches!(load(dir.join("missing.png")), Err(Error::Read { .. })));
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn every_exif_orientation_matches_the_image_crate() {
        use image::metadata::Orientation as O;
        let img = gradient(3);
        let rgb: Vec<u8> = img.data().iter().map(|v| (v * 255.0).round() as u8).collect();
        let reference = image::RgbImage::from_raw(7, 5, rgb).unwrap();
        for o in [
            O::NoTransforms,
            O::Rotate90,
            O::Rotate180,
            O::Rotate270,
            O::FlipHorizontal,
            O::FlipVertical,
            O::Rotate90FlipH,
            O::Rotate270FlipH,
        ] {
            let mut want = image::DynamicImage::ImageRgb8(reference.clone());
            want.apply_orientation(o);
            let got = oriented(img.clone(), o).unwrap();
            assert_eq!((got.width() as u32, got.height() as u32), (want.width(), want.height()), "{o:?}");
            let want = from_dynamic(want).unwrap();
            for (a, b) in got.data().iter().zip(want.data()) {
                assert!((a - b).abs() < 0.6 / 255.0, "{o:?}");
            }
        }
    }

    #[test]
    fn a_phone_photo_loads_upright() {
        // 16 x 8, left half dark; EXIF orientation 6 (rotate 90 clockwise to view).
        let rgb: Vec<u8> = (0..16 * 8).flat_map(|i| if i % 16 < 8 { [20u8; 3] } else { [230u8; 3] }).collect();
        let mut jpeg = Vec::new();
        image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 95).encode(&rgb, 16, 8, image::ExtendedColorType::Rgb8).unwrap();
        let mut tiff = b"Exif\0\0MM\0\x2a\0\0\0\x08\0\x01".to_vec();
        tiff.extend([0x01, 0x12, 0, 3, 0, 0, 0, 1, 0, 6, 0, 0, 0, 0, 0, 0]);
        let mut file = jpeg[..2].to_vec();
        file.extend([0xFF, 0xE1]);
        file.extend(((tiff.len() + 2) as u16).to_be_bytes());
        file.extend(tiff);
        file.extend(&jpeg[2..]);
        let img = decode(&file, Path::new("phone.jpg")).unwrap();
        assert_eq!(img.size(), (8, 16), "rotated upright");
        // The dark left half of the stored image is the top once rotated clockwise.
        assert!(img.at(4, 2, 0) < 0.3 && img.at(4, 13, 0) > 0.7);
    }
}
