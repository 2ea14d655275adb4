//! Running the CLI's jobs in-process for an embedding (the Python package):
//! the same command line, flags, defaults, files and manifests as the
//! `patina` binary, plus three things a program needs that a terminal does
//! not:
//! - **progress** reported to a callback (the bars are still drawn only on a
//!   terminal);
//! - **cancel**: setting the run's flag stops it at its next progress report.
//!   The stop unwinds like a panic (without printing anything), so every
//!   transactional output folder and temporary file is removed on the way,
//!   and the run returns [`Failure::Cancelled`]. Just before an output
//!   folder is moved into place, the run asks the embedding's
//!   [`Run::before_commit`] whether to go on (single-file jobs: before
//!   their first file is written): an embedding that delivers
//!   progress on another thread can thus stop a run that finished between
//!   two of its deliveries, before anything is in place;
//! - **the output images at full precision** (`f32`), as they were before
//!   8-bit encoding, keyed by the path they were written to.
//!
//! One embedded run at a time per process: a second caller waits. Each run
//! already uses every core it is given.

use patina::image::Image;
use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, RwLock};

/// A progress callback: (stage label, done, total).
pub type Progress = Arc<dyn Fn(&str, u64, u64) + Send + Sync>;

/// Asked on the run's thread just before an output folder is moved into
/// place, or a single-file job writes its first file: `false` cancels the
/// run (nothing is put in place).
pub type Barrier = Arc<dyn Fn() -> bool + Send + Sync>;

/// How an embedded run ended without finishing.
#[derive(Debug)]
pub enum Failure {
    /// `--help` or `--version` was asked for: the text the CLI prints.
    Display(String),
    /// The command line did not parse: the CLI's one-line message.
    Usage(String),
    /// The job failed: the CLI's one-line message, and whether it is bad
    /// input (exit code 2) rather than an internal error (exit code 1).
    Run { message: String, bad_input: bool },
    /// The cancel flag was set.
    Cancelled,
}

/// An image the run wrote, at full precision.
pub struct Output {
    /// Where it was written (the final path, not the staging folder's).
    pub path: PathBuf,
    pub image: Image,
}

/// What one embedded run is given.
pub struct Run<'a> {
    /// The command line, without the program name (e.g. `["synth", "ex.png", "-o", "out.png"]`).
    pub args: &'a [String],
    /// Worker threads (default: rayon's global pool, one per core).
    pub threads: Option<usize>,
    pub progress: Option<Progress>,
    pub cancel: Arc<AtomicBool>,
    /// See [`Barrier`]; `None` commits whenever the run is not cancelled.
    pub before_commit: Option<Barrier>,
}

struct Session {
    progress: Option<Progress>,
    cancel: Arc<AtomicBool>,
    before_commit: Option<Barrier>,
    outputs: Mutex<Vec<Output>>,
}

/// The session of the run in progress, if an embedding started one.
static ACTIVE: RwLock<Option<Arc<Session>>> = RwLock::new(None);
/// Held for the whole of an embedded run.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// The unwind payload of a cancelled run.
struct Cancelled;

/// Run one command line in-process; on success, the images it wrote.
pub fn run(run: Run<'_>) -> Result<Vec<Output>, Failure> {
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|p| p.into_inner());
    let argv = std::iter::once("patina".to_string()).chain(run.args.iter().cloned());
    let cli = match crate::parse(argv) {
        Ok(c) => c,
        Err(e) if crate::is_display(&e) => return Err(Failure::Display(e.to_string())),
        Err(e) => return Err(Failure::Usage(crate::parse_message(&e))),
    };
    let pool = match run.threads {
        Some(n) => Some(
            rayon::ThreadPoolBuilder::new()
                .num_threads(n.max(1))
                .build()
                .map_err(|e| Failure::Run { message: format!("cannot start {n} worker threads: {e}"), bad_input: false })?,
        ),
        None => None,
    };
    let session =
        Arc::new(Session { progress: run.progress, cancel: run.cancel, before_commit: run.before_commit, outputs: Mutex::new(Vec::new()) });
    *ACTIVE.write().unwrap_or_else(|p| p.into_inner()) = Some(session.clone());
    let result = catch_unwind(AssertUnwindSafe(|| match &pool {
        Some(pool) => pool.install(|| crate::execute(cli)),
        None => crate::execute(cli),
    }));
    *ACTIVE.write().unwrap_or_else(|p| p.into_inner()) = None;
    match result {
        Ok(Ok(())) => {
            let outputs = std::mem::take(&mut *session.outputs.lock().unwrap_or_else(|p| p.into_inner()));
            Ok(outputs.into_iter().map(|o| Output { path: unstaged(&o.path), image: o.image }).collect())
        }
        Ok(Err(e)) => Err(Failure::Run { message: crate::error_message(&e), bad_input: e.is_usage() }),
        Err(payload) if payload.is::<Cancelled>() => Err(Failure::Cancelled),
        Err(payload) => resume_unwind(payload),
    }
}

/// The progress hook of the run in progress (none outside embedded runs):
/// reports to the embedding's callback, and stops the run when its cancel
/// flag is set.
pub(crate) fn progress_hook() -> Option<impl Fn(&str, u64, u64) + Sync> {
    let session = ACTIVE.read().unwrap_or_else(|p| p.into_inner()).clone()?;
    Some(move |label: &str, done: u64, total: u64| {
        if session.cancel.load(Ordering::Relaxed) {
            resume_unwind(Box::new(Cancelled));
        }
        if let Some(p) = &session.progress {
            p(label, done, total);
        }
    })
}

/// In an embedded run, just before an output folder is moved into place
/// (or a single-file job writes its first file): stop the run (unwinding,
/// so a staging folder is removed) when it was cancelled or the
/// embedding's [`Run::before_commit`] says no.
pub(crate) fn commit_point() {
    let Some(session) = ACTIVE.read().unwrap_or_else(|p| p.into_inner()).clone() else { return };
    let go_on = !session.cancel.load(Ordering::Relaxed) && session.before_commit.as_ref().is_none_or(|b| b());
    if !go_on {
        session.cancel.store(true, Ordering::Relaxed);
        resume_unwind(Box::new(Cancelled));
    }
}

/// Whether an embedded run is in progress.
pub(crate) fn active() -> bool {
    ACTIVE.read().unwrap_or_else(|p| p.into_inner()).is_some()
}

/// Hand an image the CLI just wrote to the embedding, if one is running.
pub(crate) fn capture(path: &Path, image: &Image) {
    let session = ACTIVE.read().unwrap_or_else(|p| p.into_inner()).clone();
    if let Some(s) = session {
        s.outputs.lock().unwrap_or_else(|p| p.into_inner()).push(Output { path: path.to_path_buf(), image: image.clone() });
    }
}

/// `path` with this process's staging folder (`.NAME.patina-staging-PID`,
/// see `output::OutDir`) replaced by the folder it becomes, `NAME`.
fn unstaged(path: &Path) -> PathBuf {
    let suffix = format!(".patina-staging-{}", std::process::id());
    path.components()
        .map(|c| match c {
            Component::Normal(name) => {
                let s = name.to_string_lossy();
                match s.strip_prefix('.').and_then(|r| r.strip_suffix(&suffix)) {
                    Some(real) => PathBuf::from(real),
                    None => PathBuf::from(name),
                }
            }
            other => PathBuf::from(other.as_os_str()),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn staging_folder_names_map_to_their_outputs() {
        let pid = std::process::id();
        let p = PathBuf::from(format!("/tmp/x/.out.patina-staging-{pid}/frames/000.png"));
        assert_eq!(unstaged(&p), PathBuf::from("/tmp/x/out/frames/000.png"));
        let other = PathBuf::from("/tmp/x/.out.patina-staging-0/a.png");
        assert_eq!(unstaged(&other), other, "another process's staging folder is left alone");
    }
}
