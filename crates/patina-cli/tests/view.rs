//! `patina view` on folders the test makes: its HTTP answers (including
//! traversal attempts), and, in headless Chromium, the page itself: the time
//! slider exists, moving it changes the frame, the material's WebGL canvas
//! renders non-blank pixels that change with t.

mod scratch_support;
use patina::image::io::{save_png, BitDepth};
use patina::image::Image;
use scratch_support::Scratch;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

fn scratch(name: &str) -> Scratch {
    Scratch::new("view", name)
}

/// A weather-like output folder: four frames over t, an age map and a
/// manifest naming the frames with their times.
fn weather_folder() -> Scratch {
    let dir = scratch("weather");
    std::fs::create_dir_all(dir.join("frames")).unwrap();
    let mut frames = Vec::new();
    for i in 0..4 {
        let img = Image::from_fn(48, 40, 3, |x, y, p| {
            let rust = ((x as f32 - 24.0).powi(2) + (y as f32 - 20.0).powi(2)).sqrt() < 6.0 * i as f32;
            p.copy_from_slice(if rust { &[0.45, 0.2, 0.08] } else { &[0.6, 0.62, 0.65] });
        });
        let rel = format!("frames/frame_{i:03}.png");
        save_png(&img, dir.join(&rel), BitDepth::Eight).unwrap();
        frames.push(serde_json::json!({ "t": i as f32 / 3.0, "path": rel }));
    }
    save_png(&Image::from_fn(48, 40, 1, |x, _, p| p[0] = x as f32 / 47.0), dir.join("age_map.png"), BitDepth::Eight).unwrap();
    let manifest = serde_json::json!({
        "tool": { "name": "patina", "version": "test" }, "command": "weather", "inputs": ["rusty.png"],
        "params": { "past": 0, "future": 3 }, "seed": 1, "outputs": ["age_map.png"], "frames": frames,
        "metrics": {}, "timings_ms": {},
    });
    std::fs::write(dir.join("manifest.json"), manifest.to_string()).unwrap();
    dir
}

/// A material folder (the path) inside its scratch folder: drying wood
/// fitted with cubics.
fn material_folder() -> (Scratch, PathBuf) {
    use patina::stbrdf::{fit, procedural};
    let dir = scratch("material");
    let (frames, times) = procedural::drying_wood(40, 32, 6, 2);
    let m = fit::fit(&frames, &times, 3, procedural::drying_wood_params()).unwrap().material;
    m.save(&dir.join("mat")).unwrap();
    let path = dir.join("mat");
    (dir, path)
}

/// `patina view DIR --port 0 --no-open`, killed when dropped.
struct Server {
    child: Child,
    port: u16,
}

impl Server {
    fn start(dir: &Path) -> Server {
        let mut child = Command::new(env!("CARGO_BIN_EXE_patina"))
            .args(["view", dir.to_str().unwrap(), "--port", "0", "--no-open"])
            .stderr(Stdio::piped())
            .stdout(Stdio::null())
            .spawn()
            .unwrap();
        let mut line = String::new();
        BufReader::new(child.stderr.take().unwrap()).read_line(&mut line).unwrap();
        let port = line.split("http://127.0.0.1:").nth(1).and_then(|r| r.split('/').next()).and_then(|p| p.parse().ok());
        let port = port.unwrap_or_else(|| panic!("no address in {line:?}"));
        Server { child, port }
    }

    /// Status, headers and body of GET `path` (sent as is, unnormalised;
    /// HTTP/1.0, so the body comes whole rather than chunked).
    fn get(&self, path: &str) -> (u16, String, Vec<u8>) {
        let mut s = TcpStream::connect(("127.0.0.1", self.port)).unwrap();
        write!(s, "GET {path} HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n").unwrap();
        let mut raw = Vec::new();
        s.read_to_end(&mut raw).unwrap();
        let split = raw.windows(4).position(|w| w == b"\r\n\r\n").expect("a header block");
        let head = String::from_utf8_lossy(&raw[..split]).into_owned();
        let status = head.split_whitespace().nth(1).and_then(|c| c.parse().ok()).unwrap();
        (status, head, raw[split + 4..].to_vec())
    }

    fn url(&self) -> String {
        format!("http://127.0.0.1:{}/", self.port)
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[test]
fn view_serves_the_page_the_listing_and_files_and_refuses_traversal() {
    let dir = weather_folder();
    std::fs::write(dir.parent().unwrap().join("secret.txt"), b"outside").unwrap();
    let server = Server::start(&dir);
    let (code, head, body) = server.get("/");
    assert_eq!(code, 200);
    assert!(head.to_lowercase().contains("text/html") && String::from_utf8_lossy(&body).contains("/viewer.js"));
    let (code, _, js) = server.get("/viewer.js");
    assert!(code == 200 && String::from_utf8_lossy(&js).contains("sequenceView"));
    let (code, _, listing) = server.get("/api/listing");
    assert_eq!(code, 200);
    let listing: serde_json::Value = serde_json::from_slice(&listing).unwrap();
    assert_eq!(listing["manifest"]["frames"].as_array().unwrap().len(), 4);
    assert!(listing["files"].as_array().unwrap().iter().any(|f| f == "age_map.png"));
    let (code, head, png) = server.get("/files/frames/frame_002.png");
    assert!(code == 200 && head.contains("image/png") && png.starts_with(b"\x89PNG"), "{code} {head}");
    for bad in [
        "/../x",
        "/../secret.txt",
        "/files/../secret.txt",
        "/files/%2e%2e/secret.txt",
        "/files/frames/..%2F..%2Fsecret.txt",
        "/files//etc/passwd",
    ] {
        let (code, _, body) = server.get(bad);
        assert!(code == 403 || code == 404, "{bad}: {code}");
        assert!(!String::from_utf8_lossy(&body).contains("outside"), "{bad} leaked a file outside the folder");
    }
    assert_eq!(server.get("/files/frames/missing.png").0, 404);
    assert_eq!(server.get("/api/material.json").0, 404, "not a material folder");
}

#[test]
fn view_serves_a_materials_coefficients() {
    let (_scratch, dir) = material_folder();
    let server = Server::start(&dir);
    let (code, _, meta) = server.get("/api/material.json");
    assert_eq!(code, 200);
    let meta: serde_json::Value = serde_json::from_slice(&meta).unwrap();
    assert_eq!((meta["width"].as_u64(), meta["height"].as_u64(), meta["degree"].as_u64()), (Some(40), Some(32), Some(3)));
    let (code, _, bin) = server.get("/api/material.bin");
    assert_eq!(code, 200);
    assert_eq!(bin.len(), 40 * 32 * 7 * 4 * 4, "7 channels x 4 coefficients as f32");
}

#[test]
fn a_folder_patina_did_not_write_is_refused_in_one_line() {
    let dir = scratch("empty");
    let out = Command::new(env!("CARGO_BIN_EXE_patina")).args(["view", dir.to_str().unwrap(), "--no-open"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("manifest.json") && err.trim().lines().count() == 1, "{err}");
}

/// Chromium (or Chrome) from the system's packages, if installed.
fn chromium() -> Option<&'static str> {
    ["chromium", "chromium-browser", "google-chrome", "google-chrome-stable"]
        .into_iter()
        .find(|b| Command::new(b).arg("--version").stdout(Stdio::null()).stderr(Stdio::null()).status().is_ok_and(|s| s.success()))
}

/// The page's self-test result (`?selftest=1` writes it into
/// `<pre id="selftest">`) after Chromium ran it headless.
fn selftest(browser: &str, url: &str) -> serde_json::Value {
    let out = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-dev-shm-usage",
            "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader",
            "--virtual-time-budget=20000",
            "--dump-dom",
        ])
        .arg(format!("{url}?selftest=1"))
        .stderr(Stdio::null())
        .output()
        .unwrap();
    let dom = String::from_utf8_lossy(&out.stdout);
    let start =
        dom.find("<pre id=\"selftest\">").unwrap_or_else(|| panic!("no self-test in the page: {dom}")) + "<pre id=\"selftest\">".len();
    let end = start + dom[start..].find("</pre>").unwrap();
    let text = dom[start..end].replace("&quot;", "\"");
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {text}"))
}

#[test]
fn in_chromium_the_slider_moves_the_frame_and_the_material_renders() {
    let Some(browser) = chromium() else {
        eprintln!("SKIPPED: no chromium in PATH (apt-get install chromium; .ci/run installs it)");
        return;
    };
    let weather_dir = weather_folder();
    let weather = Server::start(&weather_dir);
    let r = selftest(browser, &weather.url());
    assert_eq!(r["view"], "sequence", "{r}");
    assert_eq!(r["slider"], true, "{r}");
    assert_eq!(r["frameChanged"], true, "moving the time slider changes the displayed frame: {r}");
    let (_material_scratch, material_dir) = material_folder();
    let material = Server::start(&material_dir);
    let r = selftest(browser, &material.url());
    assert_eq!(r["view"], "material", "{r}");
    assert_eq!(r["slider"], true, "{r}");
    assert_eq!(r["webgl"], true, "{r}");
    assert!(r["nonBlankShare"].as_f64().unwrap() > 0.3, "the WebGL canvas renders the plane and sphere: {r}");
    assert_eq!(r["frameChanged"], true, "the render changes with t: {r}");
}
