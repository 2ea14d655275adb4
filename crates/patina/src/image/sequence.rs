//! Reading image sequences (time-lapses): a folder of frames, ordered
//! naturally by file name (`f2` before `f10`), or an animated GIF. Every
//! frame must have the first frame's size and channels; the error names the
//! first frame that does not.

use super::io::{decode, read_header};
use super::Image;
use crate::error::{Error, Result};
use std::cmp::Ordering;
use std::path::{Path, PathBuf};

/// File extensions read as frames from a folder.
const FRAME_EXTENSIONS: [&str; 5] = ["png", "jpg", "jpeg", "exr", "gif"];

/// Most frames a sequence may hold. Synthesis time grows with the frame
/// count times the output's pixels; 2000 frames is four times the longest
/// sequence patina is specified for (500 frames), and far past any
/// time-lapse of the papers (tens to a few hundred frames).
pub const MAX_FRAMES: usize = 2000;

/// A loaded sequence: its frames and where each came from.
#[derive(Clone, Debug)]
pub struct Sequence {
    pub frames: Vec<Image>,
    /// One name per frame: the file path, or `FILE.gif#N`.
    pub names: Vec<String>,
}

impl Sequence {
    /// Keep frames `range` (indices into the sequence, end exclusive), then
    /// every `step`-th of them.
    pub fn subsample(self, range: std::ops::Range<usize>, step: usize) -> Result<Sequence> {
        let n = self.frames.len();
        if step == 0 {
            return Err(Error::invalid("the frame step must be at least 1"));
        }
        if range.start >= range.end || range.end > n {
            return Err(Error::invalid(format!("frames {}..{} are outside the sequence's {n} frames (0..{n})", range.start, range.end)));
        }
        let keep = |i: &usize| range.contains(i) && (i - range.start).is_multiple_of(step);
        let frames = self.frames.into_iter().enumerate().filter(|(i, _)| keep(i)).map(|(_, f)| f).collect();
        let names = self.names.into_iter().enumerate().filter(|(i, _)| keep(i)).map(|(_, f)| f).collect();
        Ok(Sequence { frames, names })
    }
}

/// Load a sequence from a folder of frames or an animated GIF.
pub fn load_sequence(path: impl AsRef<Path>) -> Result<Sequence> {
    let path = path.as_ref();
    let seq = if path.is_dir() { load_folder(path)? } else { load_gif(path)? };
    check_frames(&seq)?;
    Ok(seq)
}

/// Check that every frame has the first frame's size and channels.
pub fn check_frames(seq: &Sequence) -> Result<()> {
    let first = seq.frames.first().ok_or_else(|| Error::invalid("the sequence has no frames"))?;
    for (f, name) in seq.frames.iter().zip(&seq.names) {
        if f.size() != first.size() || f.channels() != first.channels() {
            return Err(Error::invalid(format!(
                "frame {name} is {}x{} with {} channels but the first frame is {}x{} with {}",
                f.width(),
                f.height(),
                f.channels(),
                first.width(),
                first.height(),
                first.channels()
            )));
        }
    }
    Ok(())
}

fn load_folder(dir: &Path) -> Result<Sequence> {
    let entries = std::fs::read_dir(dir).map_err(|source| Error::Read { path: dir.into(), source })?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && p.extension().and_then(|e| e.to_str()).is_some_and(|e| FRAME_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
        })
        .collect();
    if files.is_empty() {
        return Err(Error::invalid(format!("{} holds no frames (PNG, JPEG, EXR or GIF files)", dir.display())));
    }
    files.sort_by(|a, b| natural_cmp(&a.to_string_lossy(), &b.to_string_lossy()));
    check_count(files.len(), dir)?;
    // Every frame's header first: the whole sequence must fit the budget
    // (its files, all frames as f32, plus one frame's decoding) before any
    // is decoded. Each file is read once and decoded from those bytes.
    let mut files_bytes = Vec::with_capacity(files.len());
    let mut total: u128 = 0;
    let mut peak: u128 = 0;
    for f in &files {
        let bytes = std::fs::read(f).map_err(|source| Error::Read { path: f.clone(), source })?;
        let h = read_header(&bytes, f)?;
        total += (h.width * h.height * h.channels) as u128 * 4 + bytes.len() as u128;
        peak = peak.max(h.decode_bytes());
        files_bytes.push(bytes);
    }
    super::budget::check(|| format!("{} frames from {}", files.len(), dir.display()), total + peak)?;
    let frames = files.iter().zip(files_bytes).map(|(f, bytes)| decode(&bytes, f)).collect::<Result<Vec<_>>>()?;
    Ok(Sequence { frames, names: files.iter().map(|p| p.display().to_string()).collect() })
}

fn check_count(n: usize, path: &Path) -> Result<()> {
    if n > MAX_FRAMES {
        return Err(Error::invalid(format!("{} holds {n} frames; patina reads at most {MAX_FRAMES}", path.display())));
    }
    Ok(())
}

fn load_gif(path: &Path) -> Result<Sequence> {
    use image::AnimationDecoder;
    let bytes = std::fs::read(path).map_err(|source| Error::Read { path: path.into(), source })?;
    let bad = |reason: String| Error::Decode { path: path.into(), reason };
    if !bytes.starts_with(b"GIF8") {
        // A single still image is a one-frame sequence.
        let img = decode(&bytes, path)?;
        return Ok(Sequence { frames: vec![img], names: vec![path.display().to_string()] });
    }
    let header = read_header(&bytes, path)?;
    super::budget::check(|| format!("{} ({}x{})", path.display(), header.width, header.height), header.decode_bytes())?;
    let frame_bytes = (header.width * header.height) as u128 * (4 + 3 * 4);
    let decoder = image::codecs::gif::GifDecoder::new(std::io::Cursor::new(&bytes)).map_err(|e| bad(e.to_string()))?;
    // Frames one at a time, with the count and the memory checked as they come.
    let mut images = Vec::new();
    for (i, frame) in decoder.into_frames().enumerate() {
        check_count(i + 1, path)?;
        super::budget::check(|| format!("{} frames of {}", i + 1, path.display()), frame_bytes * (i as u128 + 1) + header.decode_bytes())?;
        let rgba = frame.map_err(|e| bad(e.to_string()))?.into_buffer();
        let (w, h) = (rgba.width() as usize, rgba.height() as usize);
        let data = rgba.into_raw().chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).map(|b| b as f32 / 255.0).collect();
        images.push(Image::from_data(w, h, 3, data)?);
    }
    let names = (0..images.len()).map(|i| format!("{}#{i}", path.display())).collect();
    Ok(Sequence { frames: images, names })
}

/// Natural order: runs of digits compare as numbers (`f2` < `f10`).
pub fn natural_cmp(a: &str, b: &str) -> Ordering {
    let (mut a, mut b) = (a.as_bytes(), b.as_bytes());
    loop {
        match (a.first(), b.first()) {
            (None, None) => return Ordering::Equal,
            (None, _) => return Ordering::Less,
            (_, None) => return Ordering::Greater,
            (Some(x), Some(y)) if x.is_ascii_digit() && y.is_ascii_digit() => {
                let run = |s: &[u8]| s.iter().take_while(|c| c.is_ascii_digit()).count();
                let (na, nb) = (run(a), run(b));
                let (da, db) = (&a[..na], &b[..nb]);
                let strip = |d: &[u8]| -> usize { d.iter().take_while(|&&c| c == b'0').count().min(d.len().saturating_sub(1)) };
                let (ta, tb) = (&da[strip(da)..], &db[strip(db)..]);
                let ord = ta.len().cmp(&tb.len()).then(ta.cmp(tb)).then(na.cmp(&nb));
                if ord != Ordering::Equal {
                    return ord;
                }
                a = &a[na..];
                b = &b[nb..];
            }
            (Some(x), Some(y)) => {
                if x != y {
                    return x.cmp(y);
                }
                a = &a[1..];
                b = &b[1..];
            }
        }
    }
}

/// The per-pixel mean of `frames` (one size and channel count), summed in
/// f64.
pub fn temporal_mean(frames: &[Image]) -> Result<Image> {
    use rayon::prelude::*;
    let first = frames.first().ok_or_else(|| Error::invalid("the sequence has no frames"))?;
    let mut sum = vec![0f64; first.data().len()];
    for f in frames {
        sum.par_iter_mut().zip(f.data().par_iter()).for_each(|(s, v)| *s += f64::from(*v));
    }
    let n = frames.len() as f64;
    Image::from_data(first.width(), first.height(), first.channels(), sum.iter().map(|s| (s / n) as f32).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn natural_order_reads_numbers_as_numbers() {
        let mut v = vec!["f10.png", "f2.png", "f1.png", "f02b.png", "g1.png"];
        v.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(v, ["f1.png", "f2.png", "f02b.png", "f10.png", "g1.png"]);
    }
}
