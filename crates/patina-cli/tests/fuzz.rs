//! Fuzzing in the normal suite: mutated PNG, JPEG, GIF and EXR files and
//! mutated material folders, a few hundred seeded cases each, through the
//! decoder in process and through the `patina` binary. Every case must end
//! with exit 0 or 2, one line on failure, no panic and nothing left behind.
//! `cargo run --example fuzz -p patina-cli -- CASES` runs the same mutator
//! for longer.

mod fuzz_support;

use fuzz_support::{run_case, run_material_case, seeds};
use std::path::PathBuf;

/// Cases per seed file (5 files) and for material folders.
const CASES: u64 = 300;

fn work(name: &str, i: u64) -> PathBuf {
    let d = std::env::temp_dir().join(format!("patina-fuzz-{name}-{}-{i}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Run `cases` on two threads (the CI machine's cores); the failures and
/// how many cases were accepted.
fn run_all(name: &str, cases: Vec<u64>, f: impl Fn(u64, &std::path::Path) -> Result<bool, String> + Sync) -> (Vec<String>, usize) {
    let failures = std::sync::Mutex::new(Vec::new());
    let accepted = std::sync::atomic::AtomicUsize::new(0);
    std::thread::scope(|s| {
        for lane in 0..2u64 {
            let (cases, f, failures, accepted) = (&cases, &f, &failures, &accepted);
            s.spawn(move || {
                for &c in cases.iter().skip(lane as usize).step_by(2) {
                    let dir = work(name, c);
                    match f(c, &dir) {
                        Ok(true) => _ = accepted.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
                        Ok(false) => {}
                        Err(e) => failures.lock().unwrap().push(e),
                    }
                    let _ = std::fs::remove_dir_all(&dir);
                }
            });
        }
    });
    (failures.into_inner().unwrap(), accepted.into_inner())
}

#[test]
fn mutated_images_never_panic_crash_or_leave_files() {
    let seeds = seeds();
    let cases: Vec<u64> = (0..seeds.len() as u64 * CASES).collect();
    let n = cases.len();
    let (failures, accepted) = run_all("img", cases, |c, dir| run_case(&seeds, (c % seeds.len() as u64) as usize, c, dir));
    assert!(failures.is_empty(), "{} of {n} cases failed:\n{}", failures.len(), failures.join("\n"));
    // The mutator must reach the decoders' inner paths, not only be refused at the door.
    eprintln!("{accepted} of {n} mutated images accepted");
    assert!(accepted > n / 20 && accepted < n * 19 / 20, "{accepted} of {n} mutated files were accepted");
}

#[test]
fn mutated_material_folders_never_panic_escape_or_change_the_input() {
    let (failures, accepted) = run_all("mat", (0..CASES).collect(), run_material_case);
    assert!(failures.is_empty(), "{} of {CASES} cases failed:\n{}", failures.len(), failures.join("\n"));
    eprintln!("{accepted} of {CASES} mutated materials accepted");
    assert!(accepted > 0 && accepted < CASES as usize, "{accepted} of {CASES} mutated materials were accepted");
}
