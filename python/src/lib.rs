//! `patina._native`: the Python package's native half. It runs the `patina`
//! CLI's jobs in-process (`patina_cli::embed`), so every flag, default,
//! output file and manifest is the CLI's own, and hands the output images
//! back at full precision. The Python half (`patina/__init__.py`) turns
//! keyword arguments into flags and bytes into numpy arrays.
//!
//! The work runs on its own thread with the GIL released; the calling
//! thread wakes every 50 ms to deliver progress to the Python callback and
//! to check for Ctrl-C, which cancels the run (see `embed`) and raises
//! `KeyboardInterrupt` once it has stopped and cleaned up. Before an output
//! folder is moved into place (or a single-file job writes its file), the
//! run waits for the calling thread to deliver the latest report: a
//! callback that raises then stops even a run that finished between two
//! wakes, and nothing is left behind.

use patina::image::io::{self, BitDepth};
use patina::image::Image;
use patina_cli::embed::{self, Failure};
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyByteArray;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// What the run's thread tells the calling thread.
enum Message {
    /// Outputs are about to be put in place: answer whether the run goes on.
    Commit(mpsc::Sender<bool>),
    /// The run ended.
    Done,
}

/// The latest progress report: (stage, done, total), and whether it is new.
type Latest = Arc<Mutex<(Option<(String, u64, u64)>, bool)>>;

/// One output image: (path, height, width, channels, little-endian f32 samples).
type OutputImage = (String, usize, usize, usize, Py<PyByteArray>);

/// Run one patina command line (without the program name) in-process.
///
/// Returns the images it wrote as (path, height, width, channels, f32
/// bytes). `progress(stage, done, total)` is called on this thread. Bad
/// input raises ValueError and internal errors RuntimeError, with the CLI's
/// one-line message; `--help` raises ValueError holding the help text.
#[pyfunction]
#[pyo3(signature = (args, *, threads=None, progress=None))]
fn run(py: Python<'_>, args: Vec<String>, threads: Option<usize>, progress: Option<Py<PyAny>>) -> PyResult<Vec<OutputImage>> {
    let cancel = Arc::new(AtomicBool::new(false));
    let latest: Latest = Arc::new(Mutex::new((None, false)));
    let report: embed::Progress = {
        let latest = latest.clone();
        Arc::new(move |stage: &str, done: u64, total: u64| {
            let mut l = latest.lock().unwrap_or_else(|p| p.into_inner());
            *l = (Some((stage.to_string(), done, total)), true);
        })
    };
    let (tx, rx) = mpsc::channel::<Message>();
    let rx = Mutex::new(rx);
    let worker_cancel = cancel.clone();
    let commit_tx = tx.clone();
    // Ask the calling thread, and wait for its answer (no answer: it is
    // gone, stop).
    let before_commit: embed::Barrier = Arc::new(move || {
        let (reply, answer) = mpsc::channel();
        commit_tx.send(Message::Commit(reply)).is_ok() && answer.recv().unwrap_or(false)
    });
    let worker = std::thread::Builder::new()
        .name("patina".into())
        .stack_size(16 << 20)
        .spawn(move || {
            let run =
                embed::Run { args: &args, threads, progress: Some(report), cancel: worker_cancel, before_commit: Some(before_commit) };
            let outcome = embed::run(run);
            let _ = tx.send(Message::Done);
            outcome
        })
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start the worker thread: {e}")))?;

    // Wait, waking to deliver progress and to notice Ctrl-C or a raising callback.
    let mut interrupted: Option<PyErr> = None;
    loop {
        let waited = py.detach(|| rx.lock().unwrap_or_else(|p| p.into_inner()).recv_timeout(Duration::from_millis(50)));
        if interrupted.is_none() {
            let step = py.check_signals().and_then(|()| deliver(py, &latest, progress.as_ref()));
            if let Err(e) = step {
                cancel.store(true, Ordering::Relaxed);
                interrupted = Some(e);
            }
        }
        match waited {
            // The step above has just delivered the report the run made
            // before it asked: if the callback raised (then or before),
            // nothing is put in place.
            Ok(Message::Commit(reply)) => {
                let _ = reply.send(interrupted.is_none());
            }
            Ok(Message::Done) | Err(RecvTimeoutError::Disconnected) => break,
            Err(RecvTimeoutError::Timeout) => {}
        }
    }
    let outcome = py.detach(|| worker.join());
    if interrupted.is_none() {
        deliver(py, &latest, progress.as_ref())?;
    }
    let outcome = match outcome {
        Ok(o) => o,
        Err(panic) => {
            let what = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "unknown panic".into());
            return Err(PyRuntimeError::new_err(format!("internal error (panic): {what}")));
        }
    };
    match outcome {
        Ok(outputs) => {
            if let Some(e) = interrupted {
                return Err(e);
            }
            outputs.into_iter().map(|o| to_python(py, o.path, &o.image)).collect()
        }
        Err(Failure::Cancelled) => Err(interrupted.unwrap_or_else(|| PyKeyboardInterrupt::new_err("cancelled"))),
        Err(Failure::Display(text)) => Err(PyValueError::new_err(text)),
        Err(Failure::Usage(message)) => Err(PyValueError::new_err(message)),
        Err(Failure::Run { message, bad_input }) => {
            Err(if bad_input { PyValueError::new_err(message) } else { PyRuntimeError::new_err(message) })
        }
    }
}

/// Call the progress callback if a new report arrived.
fn deliver(py: Python<'_>, latest: &Latest, progress: Option<&Py<PyAny>>) -> PyResult<()> {
    let Some(callback) = progress else { return Ok(()) };
    let report = {
        let mut l = latest.lock().unwrap_or_else(|p| p.into_inner());
        let fresh = std::mem::replace(&mut l.1, false);
        if fresh { l.0.clone() } else { None }
    };
    if let Some((stage, done, total)) = report {
        callback.call1(py, (stage, done, total))?;
    }
    Ok(())
}

fn to_python(py: Python<'_>, path: PathBuf, image: &Image) -> PyResult<OutputImage> {
    let data = image.data();
    let bytes = PyByteArray::new_with(py, data.len() * 4, |buf| {
        for (dst, v) in buf.chunks_exact_mut(4).zip(data) {
            dst.copy_from_slice(&v.to_le_bytes());
        }
        Ok(())
    })?;
    Ok((path.to_string_lossy().into_owned(), image.height(), image.width(), image.channels(), bytes.unbind()))
}

/// Write an array's samples to an image file the CLI reads back exactly:
/// `uint8` -> 8-bit PNG, `uint16` -> 16-bit PNG, `float32` -> 32-bit EXR.
/// `data` is the C-ordered samples (native byte order), `dtype` one of
/// "uint8", "uint16", "float32".
#[pyfunction]
fn write_image(path: PathBuf, data: &[u8], height: usize, width: usize, channels: usize, dtype: &str) -> PyResult<()> {
    let n = height * width * channels;
    let (samples, depth): (Vec<f32>, Option<BitDepth>) = match dtype {
        "uint8" if data.len() == n => (data.iter().map(|&v| v as f32 / 255.0).collect(), Some(BitDepth::Eight)),
        "uint16" if data.len() == 2 * n => {
            (data.chunks_exact(2).map(|b| u16::from_ne_bytes([b[0], b[1]]) as f32 / 65535.0).collect(), Some(BitDepth::Sixteen))
        }
        "float32" if data.len() == 4 * n => (data.chunks_exact(4).map(|b| f32::from_ne_bytes([b[0], b[1], b[2], b[3]])).collect(), None),
        "uint8" | "uint16" | "float32" => {
            return Err(PyValueError::new_err(format!("{} bytes do not hold a {height}x{width}x{channels} {dtype} array", data.len())))
        }
        other => return Err(PyValueError::new_err(format!("arrays must be uint8, uint16 or float32, not {other}"))),
    };
    if let Some(bad) = samples.iter().find(|v| !v.is_finite()) {
        return Err(PyValueError::new_err(format!("the array holds a non-finite value ({bad})")));
    }
    let image = Image::from_data(width, height, channels, samples).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let written = match depth {
        Some(d) => io::save_png(&image, &path, d),
        None => io::save_exr(&image, &path),
    };
    written.map_err(|e| py_error(&e))
}

/// A patina error as Python's: ValueError for bad input, RuntimeError for
/// internal errors, with the CLI's one-line message.
fn py_error(e: &patina::Error) -> PyErr {
    let message = patina_cli::error_message(e);
    if e.is_usage() {
        PyValueError::new_err(message)
    } else {
        PyRuntimeError::new_err(message)
    }
}

/// Read an image file the way the CLI does: (height, width, channels, f32 bytes).
#[pyfunction]
fn read_image(py: Python<'_>, path: PathBuf) -> PyResult<(usize, usize, usize, Py<PyByteArray>)> {
    let image = py.detach(|| io::load(&path)).map_err(|e| py_error(&e))?;
    let (_, h, w, c, bytes) = to_python(py, path, &image)?;
    Ok((h, w, c, bytes))
}

/// Write an animated GIF of image files (in order), as the CLI writes its
/// sequence previews: one palette for all frames, `delay_ms` per frame.
#[pyfunction]
fn write_gif(py: Python<'_>, frames: Vec<PathBuf>, path: PathBuf, delay_ms: u32) -> PyResult<()> {
    py.detach(|| -> patina::Result<()> {
        let images = frames.iter().map(io::load).collect::<patina::Result<Vec<Image>>>()?;
        io::save_gif(&images.iter().collect::<Vec<_>>(), &path, delay_ms)
    })
    .map_err(|e| py_error(&e))
}

/// The CLI's `--help` text for a command line (e.g. `["synth"]`).
#[pyfunction]
fn help(args: Vec<String>) -> PyResult<String> {
    let argv = std::iter::once("patina".to_string()).chain(args).chain(std::iter::once("--help".to_string()));
    match patina_cli::parse(argv) {
        Err(e) if patina_cli::is_display(&e) => Ok(e.to_string()),
        Err(e) => Err(PyValueError::new_err(patina_cli::parse_message(&e))),
        Ok(_) => Err(PyValueError::new_err("no help for this command line")),
    }
}

/// The patina version this module was built from.
#[pyfunction]
fn version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(write_image, m)?)?;
    m.add_function(wrap_pyfunction!(help, m)?)?;
    m.add_function(wrap_pyfunction!(read_image, m)?)?;
    m.add_function(wrap_pyfunction!(write_gif, m)?)?;
    m.add_function(wrap_pyfunction!(version, m)?)?;
    Ok(())
}
