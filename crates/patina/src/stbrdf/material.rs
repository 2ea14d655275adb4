//! A spatio-temporal material (Meister et al., section 4.1): named
//! parameters (Kd RGB, Ks RGB, roughness, optionally normal, height, ...),
//! each channel a degree-d polynomial in t on [0, 1], stored as one
//! multi-channel coefficient image.
//!
//! On disk a material is a folder with one EXR per parameter and
//! coefficient, `{Name}-{i}.exr` (the layout of meistdan/tsvbrdf:
//! `Diffuse-0.exr` ... `Diffuse-3.exr`, `Specular-i`, `Roughness-i`,
//! `Normal-i`, `Height-i`), plus `material.json` (degree, parameters and
//! their channel counts). A tsvbrdf folder without `material.json` loads
//! too: the degree is read from the file names, and single-valued
//! parameters stored as three equal channels (roughness, height) are
//! reduced to one.

use super::poly::{evaluate, MAX_DEGREE};
use crate::error::{Error, Result};
use crate::image::io::{load, save_exr};
use crate::image::resample::{resize, Filter};
use crate::image::{ChannelGroup, Image};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::ops::Range;
use std::path::Path;

/// One named material parameter and its channel count.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Param {
    /// File-name stem: `Diffuse`, `Specular`, `Roughness`, `Normal`, `Height`, ...
    pub name: String,
    pub channels: usize,
}

/// How a material's colour parameters (Diffuse, Specular) are encoded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Encoding {
    /// sRGB-encoded values: materials fitted to 8-bit photos and captures.
    Srgb,
    /// Linear values: EXR materials and physically based authoring tools.
    #[default]
    Linear,
}

/// The description written to `material.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Descriptor {
    degree: usize,
    params: Vec<Param>,
    /// Absent in files written before it existed: linear.
    #[serde(default)]
    encoding: Encoding,
}

/// A material whose every channel is a polynomial in time.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub degree: usize,
    pub params: Vec<Param>,
    /// The colour parameters' encoding (previews decode them; transfer
    /// matches a target to it). [`Material::new`] makes it linear.
    pub encoding: Encoding,
    /// (sum of parameter channels) x (degree + 1) channels: parameter
    /// channel c's coefficient k is channel c (degree + 1) + k.
    pub coefficients: Image,
}

/// Most channels one parameter may have (a material is untrusted input).
pub const MAX_PARAM_CHANNELS: usize = 64;

/// Refuse parameters that could not be a material's: names that are not a
/// plain identifier (they become file names, so `../x` or `/abs` would
/// read and write outside the folder), channel counts outside
/// 1..=[`MAX_PARAM_CHANNELS`], repeated names, or none at all.
pub fn check_params(params: &[Param]) -> Result<()> {
    if params.is_empty() || params.len() > MAX_PARAM_CHANNELS {
        return Err(Error::invalid(format!("a material needs 1 to {MAX_PARAM_CHANNELS} parameters, got {}", params.len())));
    }
    for (i, p) in params.iter().enumerate() {
        let safe = !p.name.is_empty()
            && p.name.len() <= 64
            && p.name.starts_with(|c: char| c.is_ascii_alphabetic())
            && p.name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !safe {
            return Err(Error::invalid(format!(
                "parameter name {:?} is not a plain name (a letter, then letters, digits or _; at most 64)",
                p.name
            )));
        }
        if !(1..=MAX_PARAM_CHANNELS).contains(&p.channels) {
            return Err(Error::invalid(format!("parameter {} has {} channels; 1 to {MAX_PARAM_CHANNELS} are allowed", p.name, p.channels)));
        }
        if params[..i].iter().any(|q| q.name.eq_ignore_ascii_case(&p.name)) {
            return Err(Error::invalid(format!("parameter {} is listed twice", p.name)));
        }
    }
    Ok(())
}

/// Parameter names tsvbrdf uses, in its order.
const TSVBRDF_NAMES: [&str; 5] = ["Diffuse", "Specular", "Roughness", "Normal", "Height"];

impl Material {
    /// A material from its parts, checking that they agree.
    pub fn new(degree: usize, params: Vec<Param>, coefficients: Image) -> Result<Self> {
        if !(1..=MAX_DEGREE).contains(&degree) {
            return Err(Error::invalid(format!("the polynomial degree must be 1..={MAX_DEGREE}, got {degree}")));
        }
        check_params(&params)?;
        let channels: usize = params.iter().map(|p| p.channels).sum();
        if channels * (degree + 1) != coefficients.channels() {
            return Err(Error::invalid(format!(
                "a degree-{degree} material with {channels} parameter channels needs {} coefficient channels, got {}",
                channels * (degree + 1),
                coefficients.channels()
            )));
        }
        let mut coefficients = coefficients;
        coefficients.set_groups(groups(&params, degree + 1))?;
        Ok(Material { degree, params, encoding: Encoding::Linear, coefficients })
    }

    /// Parameter channels (the channel count of an evaluated frame).
    pub fn channels(&self) -> usize {
        self.params.iter().map(|p| p.channels).sum()
    }

    pub fn size(&self) -> (usize, usize) {
        self.coefficients.size()
    }

    /// The evaluated channels of parameter `name`.
    pub fn param(&self, name: &str) -> Option<Range<usize>> {
        param_range(&self.params, name)
    }

    /// Every parameter at time t (Horner's rule per channel), named groups.
    pub fn evaluate(&self, t: f32) -> Image {
        let (w, h) = self.size();
        let (c, m) = (self.channels(), self.degree + 1);
        let mut out = Image::new(w, h, c);
        out.data_mut().par_chunks_mut(w * c).enumerate().for_each(|(y, row)| {
            let src = self.coefficients.row(y);
            for (o, a) in row.iter_mut().zip(src.chunks_exact(m)) {
                *o = evaluate(a, t);
            }
        });
        out.set_groups(groups(&self.params, 1)).expect("groups tile the channels");
        out
    }

    /// The material drawn at `scale` times its size (0.5: its features at
    /// half their size), its coefficients resampled with a Catmull-Rom
    /// filter (antialiased when shrinking). Exact in time: the polynomial
    /// map is linear in the coefficients, so this equals resampling the
    /// evaluated maps at every t.
    pub fn scaled(&self, scale: f32) -> Result<Self> {
        let (w, h) = self.size();
        let side = |v: usize| ((v as f32 * scale).round() as usize).max(1);
        if !(scale.is_finite() && scale > 0.0) {
            return Err(Error::invalid(format!("the material scale must be a positive number, got {scale}")));
        }
        let coefficients = resize(&self.coefficients, side(w), side(h), Filter::Cubic)?;
        let mut out = Material::new(self.degree, self.params.clone(), coefficients)?;
        out.encoding = self.encoding;
        Ok(out)
    }

    /// Write `dir/{Name}-{i}.exr` for every parameter and coefficient,
    /// `dir/material.json` and `dir/README.md` ([`Material::readme`]). The
    /// folder is created if missing.
    pub fn save(&self, dir: &Path) -> Result<()> {
        std::fs::create_dir_all(dir).map_err(|source| Error::Write { path: dir.into(), source })?;
        let m = self.degree + 1;
        let mut start = 0;
        for p in &self.params {
            for k in 0..m {
                let (w, h) = self.size();
                let img = Image::from_fn(w, h, p.channels, |x, y, px| {
                    let src = self.coefficients.pixel(x, y);
                    for (c, v) in px.iter_mut().enumerate() {
                        *v = src[(start + c) * m + k];
                    }
                });
                save_exr(&img, dir.join(format!("{}-{k}.exr", p.name)))?;
            }
            start += p.channels;
        }
        let desc = Descriptor { degree: self.degree, params: self.params.clone(), encoding: self.encoding };
        crate::image::io::write_atomic(&dir.join("material.json"), |buf| {
            serde_json::to_writer_pretty(&mut *buf, &desc).map_err(|e| Error::Internal(format!("material.json: {e}")))?;
            buf.push(b'\n');
            Ok(())
        })?;
        crate::image::io::write_atomic(&dir.join("README.md"), |buf| {
            buf.extend_from_slice(self.readme().as_bytes());
            Ok(())
        })
    }

    /// The README written beside a saved material: what the files hold and
    /// how to evaluate them, for a DCC tool or an engine.
    pub fn readme(&self) -> String {
        let m = self.degree + 1;
        let (w, h) = self.size();
        let mut s = format!(
            "# Spatio-temporal material (patina)\n\n\
             A {w} x {h} material whose every parameter is a degree-{} polynomial in time t on [0, 1]\n\
             (Meister et al., \"Spatio-temporal BRDF\", 2021):\n\n    p(t) = a_0 + a_1 t + ... + a_{} t^{}\n\n\
             ## Files\n\n| parameter | channels | coefficient textures |\n|---|---|---|\n",
            self.degree, self.degree, self.degree
        );
        for p in &self.params {
            let files: Vec<String> = (0..m).map(|k| format!("`{}-{k}.exr`", p.name)).collect();
            s += &format!("| {} | {} | {} |\n", p.name, p.channels, files.join(", "));
        }
        s += &format!(
            "\n`{{Name}}-{{i}}.exr` holds coefficient a_i of every channel of parameter Name (32-bit float EXR;\n\
             single-channel parameters in one channel). `material.json` lists the degree, the parameters in order and\n\
             the colour encoding. Load the EXRs as linear data (no sRGB decoding), evaluate p(t) per texel, then:\n\n\
             - Diffuse and Specular are {}.\n\
             - Specular is the Fresnel reflectance at normal incidence (F0); Roughness is GGX alpha = roughness^2;\n  \
             Normal is a tangent-space normal map (n = 2 rgb - 1); Height is a height map.\n\n\
             ## Use\n\n\
             - `patina stbrdf render THIS_FOLDER -o OUT` writes previews and shaders that evaluate the material on the GPU\n  \
             (`material.wgsl`, `material.glsl`, `material.hlsl`, and `material.shader` for Unity's built-in pipeline).\n\
             - `patina stbrdf enlarge` and `patina stbrdf transfer` take this folder as input.\n\
             - The same layout as meistdan/tsvbrdf (`Diffuse-0.exr` ...), whose tools read it too.\n",
            match self.encoding {
                Encoding::Srgb => "sRGB-encoded values (fitted to 8-bit photos): decode them to linear after evaluating",
                Encoding::Linear => "linear values",
            }
        );
        s
    }

    /// Load a material folder: ours (with `material.json`) or tsvbrdf's.
    pub fn load(dir: &Path) -> Result<Self> {
        if !dir.is_dir() {
            return Err(Error::invalid(format!("{} is not a material folder", dir.display())));
        }
        let json = dir.join("material.json");
        let (degree, declared, encoding) = if json.is_file() {
            let text = std::fs::read_to_string(&json).map_err(|source| Error::Read { path: json.clone(), source })?;
            let d: Descriptor = serde_json::from_str(&text).map_err(|e| Error::Decode { path: json.clone(), reason: e.to_string() })?;
            (d.degree, Some(d.params), d.encoding)
        } else {
            let degree = (1..=MAX_DEGREE)
                .rev()
                .find(|k| dir.join(format!("Diffuse-{k}.exr")).is_file())
                .ok_or_else(|| Error::invalid(format!("{} has neither material.json nor Diffuse-1.exr", dir.display())))?;
            (degree, None, Encoding::Linear)
        };
        if !(1..=MAX_DEGREE).contains(&degree) {
            return Err(Error::invalid(format!("{}: degree {degree} is outside 1..={MAX_DEGREE}", json.display())));
        }
        if let Some(ps) = &declared {
            check_params(ps).map_err(|e| Error::invalid(format!("{}: {e}", json.display())))?;
        }
        let names: Vec<String> = match &declared {
            Some(ps) => ps.iter().map(|p| p.name.clone()).collect(),
            None => TSVBRDF_NAMES.iter().filter(|n| dir.join(format!("{n}-0.exr")).is_file()).map(|n| n.to_string()).collect(),
        };
        let m = degree + 1;
        let mut planes: Vec<Vec<Image>> = Vec::new();
        for name in &names {
            let imgs = (0..m).map(|k| load(dir.join(format!("{name}-{k}.exr")))).collect::<Result<Vec<_>>>()?;
            planes.push(imgs);
        }
        let first =
            planes.first().and_then(|p| p.first()).ok_or_else(|| Error::invalid(format!("{} holds no parameters", dir.display())))?;
        let (w, h) = first.size();
        for (name, imgs) in names.iter().zip(&planes) {
            if let Some(bad) = imgs.iter().position(|i| i.size() != (w, h) || i.channels() != imgs[0].channels()) {
                return Err(Error::invalid(format!("{name}-{bad}.exr does not match the size and channels of the other coefficient maps")));
            }
        }
        let params: Vec<Param> = match declared {
            Some(ps) => ps,
            None => names
                .iter()
                .zip(&planes)
                .map(|(n, imgs)| {
                    let c = imgs[0].channels();
                    let single = matches!(n.as_str(), "Roughness" | "Height") && imgs.iter().all(equal_channels);
                    Param { name: n.clone(), channels: if single { 1 } else { c } }
                })
                .collect(),
        };
        for (p, imgs) in params.iter().zip(&planes) {
            if imgs[0].channels() < p.channels {
                return Err(Error::invalid(format!(
                    "{}-0.exr has {} channels but {} are declared",
                    p.name,
                    imgs[0].channels(),
                    p.channels
                )));
            }
        }
        let total: usize = params.iter().map(|p| p.channels).sum();
        let coefficients = Image::from_fn(w, h, total * m, |x, y, px| {
            let mut c0 = 0;
            for (p, imgs) in params.iter().zip(&planes) {
                for c in 0..p.channels {
                    for (k, img) in imgs.iter().enumerate() {
                        px[(c0 + c) * m + k] = img.pixel(x, y)[c];
                    }
                }
                c0 += p.channels;
            }
        });
        let mut material = Material::new(degree, params, coefficients)?;
        material.encoding = encoding;
        Ok(material)
    }
}

/// The channels of parameter `name` (case-insensitive) in a frame holding
/// `params` in order.
pub fn param_range(params: &[Param], name: &str) -> Option<Range<usize>> {
    let mut start = 0;
    for p in params {
        if p.name.eq_ignore_ascii_case(name) {
            return Some(start..start + p.channels);
        }
        start += p.channels;
    }
    None
}

/// One named channel group per parameter, each `per` channels per
/// parameter channel (1 for an evaluated frame, d + 1 for coefficients).
fn groups(params: &[Param], per: usize) -> Vec<ChannelGroup> {
    let mut start = 0;
    params
        .iter()
        .map(|p| {
            let g = ChannelGroup { name: p.name.to_lowercase(), channels: start * per..(start + p.channels) * per };
            start += p.channels;
            g
        })
        .collect()
}

fn equal_channels(img: &Image) -> bool {
    let c = img.channels();
    img.data().chunks_exact(c).all(|p| p.iter().all(|v| *v == p[0]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn material() -> Material {
        let params = vec![
            Param { name: "Diffuse".into(), channels: 3 },
            Param { name: "Specular".into(), channels: 3 },
            Param { name: "Roughness".into(), channels: 1 },
        ];
        let coef = Image::from_fn(8, 6, 7 * 4, |x, y, p| {
            for (i, v) in p.iter_mut().enumerate() {
                *v = ((x * 7 + y * 3 + i * 5) % 11) as f32 / 11.0 - 0.3;
            }
        });
        Material::new(3, params, coef).unwrap()
    }

    #[test]
    fn a_material_round_trips_through_its_folder_and_evaluates_by_horner() {
        let m = material();
        let dir = std::env::temp_dir().join(format!("patina-material-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        m.save(&dir).unwrap();
        assert!(dir.join("Diffuse-3.exr").is_file() && dir.join("Roughness-0.exr").is_file());
        assert_eq!(Material::load(&dir).unwrap(), m);
        // Without material.json it is read as a tsvbrdf folder.
        std::fs::remove_file(dir.join("material.json")).unwrap();
        let t = Material::load(&dir).unwrap();
        assert_eq!((t.degree, t.channels()), (3, 7));
        let frame = m.evaluate(0.3);
        let a = &m.coefficients.pixel(2, 1)[6 * 4..7 * 4];
        let want = a[0] + 0.3 * a[1] + 0.09 * a[2] + 0.027 * a[3];
        assert!((frame.pixel(2, 1)[6] - want).abs() < 1e-6);
        assert_eq!(m.param("roughness"), Some(6..7));
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A scaled material evaluates, at every time, to its evaluated maps
    /// resized the same way; its size is the scale's; a scale that is not
    /// positive is refused.
    #[test]
    fn a_scaled_material_is_its_maps_resized_at_every_time() {
        let mut m = material();
        m.encoding = Encoding::Srgb;
        let half = m.scaled(0.5).unwrap();
        assert_eq!((half.size(), half.encoding, half.degree), ((4, 3), Encoding::Srgb, 3));
        for t in [0.0, 0.4, 1.0] {
            let want = resize(&m.evaluate(t), 4, 3, Filter::Cubic).unwrap();
            let got = half.evaluate(t);
            let off = got.data().iter().zip(want.data()).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
            assert!(off < 1e-5, "t = {t}: {off}");
        }
        assert_eq!(m.scaled(2.0).unwrap().size(), (16, 12));
        assert!(m.scaled(0.0).is_err() && m.scaled(f32::NAN).is_err());
    }
}
