//! Output conventions: manifests beside outputs, never writing over an
//! input, and size parsing shared by the subcommands.

use patina::image::io::{self, save_gif, BitDepth};
use patina::image::Image;
use patina::{Error, Result};
use rayon::prelude::*;
use serde::Serialize;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What a run records beside its outputs (see DESIGN.md, "Outputs").
#[derive(Serialize)]
pub struct Manifest {
    pub tool: Tool,
    pub command: String,
    pub inputs: Vec<PathBuf>,
    pub params: Value,
    pub seed: u64,
    pub outputs: Vec<PathBuf>,
    /// Sequences: every frame with its time value.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub frames: Vec<FrameEntry>,
    pub metrics: BTreeMap<String, Value>,
    pub timings_ms: BTreeMap<String, f64>,
}

/// One frame of a sequence in the manifest.
#[derive(Serialize)]
pub struct FrameEntry {
    pub t: f32,
    pub path: PathBuf,
}

#[derive(Serialize)]
pub struct Tool {
    pub name: &'static str,
    pub version: &'static str,
}

impl Manifest {
    pub fn new(command: &str, seed: u64) -> Self {
        Manifest {
            tool: Tool { name: "patina", version: env!("CARGO_PKG_VERSION") },
            command: command.to_string(),
            inputs: Vec::new(),
            params: Value::Null,
            seed,
            outputs: Vec::new(),
            frames: Vec::new(),
            metrics: BTreeMap::new(),
            timings_ms: BTreeMap::new(),
        }
    }

    /// Write as pretty JSON, atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        patina::image::io::write_atomic(path, |buf| {
            serde_json::to_writer_pretty(&mut *buf, self).map_err(|e| Error::Internal(format!("manifest: {e}")))?;
            buf.push(b'\n');
            Ok(())
        })
    }
}

/// Stage timer feeding `timings_ms`.
pub struct Stopwatch(Instant);

impl Stopwatch {
    pub fn start() -> Self {
        Stopwatch(Instant::now())
    }
    /// Milliseconds since start (or the last lap), restarting the clock.
    pub fn lap(&mut self) -> f64 {
        let ms = self.0.elapsed().as_secs_f64() * 1000.0;
        self.0 = Instant::now();
        ms
    }
}

/// The absolute form of `p`, resolving what exists (symlinks included).
fn resolved(p: &Path) -> PathBuf {
    if let Ok(c) = p.canonicalize() {
        return c;
    }
    let parent = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    match (parent.canonicalize(), p.file_name()) {
        (Ok(d), Some(name)) => d.join(name),
        _ => p.to_path_buf(),
    }
}

/// Refuse to write any of the single-file `outputs` over one of `inputs`,
/// and check each output's folder exists.
pub fn check_outputs(outputs: &[&Path], inputs: &[&Path]) -> Result<()> {
    for out in outputs {
        let r = resolved(out);
        if let Some(inp) = inputs.iter().find(|i| resolved(i) == r) {
            return Err(Error::invalid(format!("output {} would overwrite input {}", out.display(), inp.display())));
        }
        if r.is_dir() {
            return Err(Error::invalid(format!("output {} is a folder", out.display())));
        }
        let parent = out.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        if !parent.is_dir() {
            return Err(Error::invalid(format!("output folder {} does not exist", parent.display())));
        }
    }
    Ok(())
}

/// An output folder written as a transaction: everything goes into a
/// staging folder beside OUT (`.NAME.patina-staging-PID`), which is renamed
/// into place by [`OutDir::commit`] once every file is written. A failure or
/// a kill before then leaves OUT as it was (absent, or the previous complete
/// run); the staging folder is removed on failure, and a later run removes
/// those of processes that no longer exist.
pub struct OutDir {
    target: PathBuf,
    staging: PathBuf,
    committed: bool,
}

/// Name prefix of the hidden folders patina keeps beside OUT.
fn hidden_prefix(name: &std::ffi::OsStr) -> String {
    format!(".{}.patina-", name.to_string_lossy())
}

impl OutDir {
    /// Start writing `out`. Refused (as bad input) when OUT is a file, when
    /// it is, holds or lies inside an input, when its parent folder does not
    /// exist, or when it exists and is not empty, unless `overwrite` is set
    /// and it is a folder patina wrote (it has patina's `manifest.json`).
    pub fn begin(out: &Path, inputs: &[&Path], overwrite: bool) -> Result<OutDir> {
        let target = resolved(out);
        let name = target.file_name().ok_or_else(|| Error::invalid(format!("{} is not a folder name", out.display())))?.to_owned();
        let parent = target.parent().ok_or_else(|| Error::invalid(format!("{} is not a folder name", out.display())))?.to_path_buf();
        if !parent.is_dir() {
            return Err(Error::invalid(format!("output folder {}'s parent does not exist", out.display())));
        }
        if target.exists() && !target.is_dir() {
            return Err(Error::invalid(format!("output {} exists and is not a folder", out.display())));
        }
        for input in inputs {
            let i = resolved(input);
            if i == target || i.starts_with(&target) {
                return Err(Error::invalid(format!("output folder {} would overwrite input {}", out.display(), input.display())));
            }
            if i.is_dir() && target.starts_with(&i) {
                return Err(Error::invalid(format!("output folder {} lies inside input folder {}", out.display(), input.display())));
            }
        }
        let empty = target.read_dir().map(|mut d| d.next().is_none()).unwrap_or(true);
        if target.is_dir() && !empty {
            if !overwrite {
                return Err(Error::invalid(format!("output folder {} exists; pass --overwrite to replace it", out.display())));
            }
            if !written_by_patina(&target) {
                return Err(Error::invalid(format!(
                    "output folder {} was not written by patina (no patina manifest.json); refusing to replace it",
                    out.display()
                )));
            }
        }
        remove_stale(&parent, &name);
        let staging = parent.join(format!("{}staging-{}", hidden_prefix(&name), std::process::id()));
        let _ = std::fs::remove_dir_all(&staging);
        std::fs::create_dir(&staging).map_err(|source| Error::Write { path: staging.clone(), source })?;
        Ok(OutDir { target, staging, committed: false })
    }

    /// The folder to write into until [`OutDir::commit`].
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// Move the finished folder into place, replacing the previous one
    /// (in an embedded run, unless it is stopped there: see
    /// [`crate::embed::commit_point`]).
    pub fn commit(mut self) -> Result<()> {
        crate::embed::commit_point();
        let werr = |path: &Path| {
            let path = path.to_path_buf();
            move |source| Error::Write { path, source }
        };
        if self.target.exists() {
            let name = self.target.file_name().unwrap_or_default().to_owned();
            let old = self.target.with_file_name(format!("{}old-{}", hidden_prefix(&name), std::process::id()));
            let _ = std::fs::remove_dir_all(&old);
            std::fs::rename(&self.target, &old).map_err(werr(&self.target))?;
            if let Err(e) = std::fs::rename(&self.staging, &self.target) {
                let _ = std::fs::rename(&old, &self.target);
                return Err(werr(&self.target)(e));
            }
            let _ = std::fs::remove_dir_all(&old);
        } else {
            std::fs::rename(&self.staging, &self.target).map_err(werr(&self.target))?;
        }
        self.committed = true;
        Ok(())
    }
}

impl Drop for OutDir {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

/// True when `dir/manifest.json` is one patina wrote.
fn written_by_patina(dir: &Path) -> bool {
    std::fs::read(dir.join("manifest.json"))
        .ok()
        .and_then(|b| serde_json::from_slice::<Value>(&b).ok())
        .is_some_and(|m| m["tool"]["name"] == "patina")
}

/// Remove the staging and old folders beside `parent/name` left by patina
/// processes that no longer run (killed, or the machine went down).
fn remove_stale(parent: &Path, name: &std::ffi::OsStr) {
    let prefix = hidden_prefix(name);
    let Ok(entries) = std::fs::read_dir(parent) else { return };
    for e in entries.flatten() {
        let file = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = file.strip_prefix(&prefix) else { continue };
        let pid = rest.strip_prefix("staging-").or_else(|| rest.strip_prefix("old-")).and_then(|p| p.parse::<u32>().ok());
        if pid.is_some_and(|p| p != std::process::id() && !process_alive(p)) {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

/// Whether process `pid` exists. Where the system cannot tell (no /proc),
/// a leftover folder is assumed live and kept: better a stray folder than
/// deleting another run's work.
fn process_alive(pid: u32) -> bool {
    let proc = Path::new("/proc");
    !proc.is_dir() || proc.join(pid.to_string()).exists()
}

/// `path` with `.manifest.json` appended (OUT -> OUT.manifest.json).
pub fn manifest_path(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".manifest.json");
    PathBuf::from(s)
}

/// Parse `WxH` (e.g. `512x384`); both sides >= 1.
pub fn parse_size(s: &str) -> std::result::Result<(usize, usize), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("'{s}' is not WIDTHxHEIGHT (e.g. 512x512)"))?;
    let side = |v: &str| v.trim().parse::<usize>().map_err(|_| format!("'{s}' is not WIDTHxHEIGHT (e.g. 512x512)"));
    let (w, h) = (side(w)?, side(h)?);
    if w == 0 || h == 0 {
        return Err(format!("size {w}x{h} is empty: both sides must be at least 1"));
    }
    Ok((w, h))
}

/// Write an image output as PNG (and hand it to an embedding, see
/// [`crate::embed`]).
pub fn save_png(img: &Image, path: impl AsRef<Path>, depth: BitDepth) -> Result<()> {
    io::save_png(img, path.as_ref(), depth)?;
    crate::embed::capture(path.as_ref(), img);
    Ok(())
}

/// Write an image output as PNG or EXR by its extension (and hand it to an
/// embedding).
pub fn save(img: &Image, path: impl AsRef<Path>, depth: BitDepth) -> Result<()> {
    io::save(img, path.as_ref(), depth)?;
    crate::embed::capture(path.as_ref(), img);
    Ok(())
}

/// Set while `patina demo` runs a subcommand into its staging folder: the
/// demo says where everything went once it is in place.
pub static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Print a run's closing summary line on stderr (not in embedded runs,
/// whose caller gets the manifest instead, nor inside the demo).
pub fn summary(line: String) {
    if !crate::embed::active() && !QUIET.load(std::sync::atomic::Ordering::Relaxed) {
        eprintln!("{line}");
    }
}

/// Create `dir` (and its parents).
pub fn mkdir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|source| Error::Write { path: dir.into(), source })
}

/// Write a sequence of (t, frame) under `dir`: frames/NNN.png (encoded in
/// parallel) and sequence.gif, each recorded in the manifest.
pub fn write_sequence(dir: &Path, frames: &[(f32, &Image)], gif_delay_ms: u32, manifest: &mut Manifest) -> Result<()> {
    write_sequence_from(dir, 0, frames, gif_delay_ms, manifest)
}

/// [`write_sequence`] for part of a sequence whose first frame is number
/// `first` of the whole (the frames keep their numbers in the whole).
pub fn write_sequence_from(dir: &Path, first: usize, frames: &[(f32, &Image)], gif_delay_ms: u32, manifest: &mut Manifest) -> Result<()> {
    let frames_dir = dir.join("frames");
    mkdir(&frames_dir)?;
    let rels: Vec<PathBuf> = (first..first + frames.len()).map(|i| PathBuf::from("frames").join(format!("{i:03}.png"))).collect();
    frames.par_iter().zip(&rels).try_for_each(|((_, f), rel)| save_png(f, dir.join(rel), BitDepth::Eight))?;
    manifest.frames.extend(frames.iter().zip(rels).map(|((t, _), path)| FrameEntry { t: *t, path }));
    let images: Vec<&Image> = frames.iter().map(|(_, f)| *f).collect();
    save_gif(&images, dir.join("sequence.gif"), gif_delay_ms)?;
    manifest.outputs.push("sequence.gif".into());
    Ok(())
}

/// Two images side by side, top-aligned, on dark grey (8 px apart), with
/// the second one's channels (for comparison GIFs).
pub fn side_by_side(input: &Image, output: &Image) -> Image {
    const GAP: usize = 8;
    let c = output.channels();
    let (w, h) = (input.width() + GAP + output.width(), input.height().max(output.height()));
    Image::from_fn(w, h, c, |x, y, p| {
        let src = if x < input.width() && y < input.height() {
            Some(input.pixel(x, y))
        } else if x >= input.width() + GAP && y < output.height() {
            Some(output.pixel(x - input.width() - GAP, y))
        } else {
            None
        };
        match src {
            Some(s) => p.iter_mut().zip(s.iter().cycle()).for_each(|(d, v)| *d = *v),
            None => p.iter_mut().for_each(|d| *d = 0.15),
        }
    })
}
