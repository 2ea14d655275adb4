//! The declared `rust-version` is true: no locked dependency needs a newer
//! compiler. (Only one toolchain is installable here, so the declared
//! version cannot be built directly; this checks every dependency's own
//! declaration instead.)

fn version(v: &str) -> Vec<u32> {
    let mut parts: Vec<u32> = v.split('.').map(|p| p.parse().unwrap_or(0)).collect();
    parts.resize(3, 0);
    parts
}

/// The compiler's host triple, from `rustc -vV`.
fn host_triple() -> String {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let out = std::process::Command::new(rustc).arg("-vV").output().expect("rustc -vV runs");
    let text = String::from_utf8_lossy(&out.stdout);
    text.lines().find_map(|l| l.strip_prefix("host: ")).expect("rustc -vV names its host").trim().to_string()
}

#[test]
fn declared_rust_version_covers_every_locked_dependency() {
    // Only the host's dependency graph: the one `cargo test` has fetched.
    // Offline first (a fresh machine has no other platform's crates, and a
    // sandbox may have no network); if something is still missing, let
    // cargo fetch it.
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let host = host_triple();
    let metadata = |offline: bool| {
        let mut cmd = std::process::Command::new(&cargo);
        cmd.args(["metadata", "--format-version", "1", "--locked", "--filter-platform", host.as_str()]);
        if offline {
            cmd.arg("--offline");
        }
        cmd.current_dir(env!("CARGO_MANIFEST_DIR")).output().expect("cargo metadata runs")
    };
    let mut out = metadata(true);
    if !out.status.success() {
        out = metadata(false);
    }
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let declared = version(env!("CARGO_PKG_RUST_VERSION"));
    let packages = meta["packages"].as_array().unwrap();
    assert!(packages.len() > 10, "the dependency graph was read");
    for p in packages {
        if let Some(rv) = p["rust_version"].as_str() {
            assert!(version(rv) <= declared, "{} {} needs Rust {rv}, newer than the declared {:?}", p["name"], p["version"], declared);
        }
    }
}
