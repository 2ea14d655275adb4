//! The fuzz test's mutator for as long as you like:
//! `cargo run --release -p patina-cli --example fuzz -- [CASES] [FIRST_SEED]`
//! (default 10000 cases from seed 0). Needs the `patina` binary built
//! (`cargo build --release -p patina-cli`). Prints each failing case with
//! the seed that replays it.

#[path = "../tests/fuzz_support/mod.rs"]
mod fuzz_support;

fn main() {
    let args: Vec<u64> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let (cases, first) = (args.first().copied().unwrap_or(10_000), args.get(1).copied().unwrap_or(0));
    let seeds = fuzz_support::seeds();
    let dir = std::env::temp_dir().join(format!("patina-fuzz-long-{}", std::process::id()));
    let mut failed = 0;
    for c in first..first + cases {
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let k = (c % (seeds.len() as u64 + 1)) as usize;
        let r = if k == seeds.len() { fuzz_support::run_material_case(c, &dir) } else { fuzz_support::run_case(&seeds, k, c, &dir) };
        if let Err(e) = r.map(|_| ()) {
            failed += 1;
            println!("FAIL {e}");
        }
        if (c - first + 1) % 500 == 0 {
            eprintln!("{} cases, {failed} failed", c - first + 1);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    println!("{cases} cases from seed {first}: {failed} failed");
    std::process::exit(i32::from(failed > 0));
}
