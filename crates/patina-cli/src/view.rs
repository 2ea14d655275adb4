//! `patina view DIR`: a local web viewer for any patina output folder.
//!
//! A single page (HTML, JS and CSS embedded in the binary, no network)
//! served on 127.0.0.1 only by tiny_http. The page reads the folder's
//! `manifest.json` and listing from `/api/listing` and shows:
//! - sequences (weather, ttf, stone, decay, stbrdf render): a time slider
//!   labelled in t, play/pause, a before/after wipe against the first
//!   frame, the folder's other images (age map, intact, degree, tendency,
//!   masks) as side panels, zoom 1:1 and 2:1 with pan;
//! - materials (a folder with `material.json`): a WebGL2 sphere and plane
//!   shaded from the coefficient textures (`/api/material.json` and
//!   `/api/material.bin`, the coefficients as little-endian f32) with the
//!   same GGX model as the previews, the polynomials evaluated live at the
//!   slider's t, and the maps at that t;
//! - synthesis: exemplar and outputs side by side;
//! - the manifest's parameters in a collapsible panel.
//!
//! Files are served from `/files/PATH` only when PATH, decoded and
//! normalised, stays inside DIR (no `..`, no absolute paths, symlinks
//! resolved); anything else is refused with 403 or 404.

use patina::stbrdf::Material;
use patina::{Error, Result};
use serde_json::json;
use std::path::{Component, Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// A patina output folder (it holds a manifest.json), or a material folder (material.json).
    pub dir: PathBuf,
    /// Port on 127.0.0.1 (0 picks a free one).
    #[arg(long, default_value_t = 8765)]
    pub port: u16,
    /// Do not open a browser; only print the address.
    #[arg(long)]
    pub no_open: bool,
}

const INDEX_HTML: &str = include_str!("view/index.html");
const VIEWER_JS: &str = include_str!("view/viewer.js");
const VIEWER_CSS: &str = include_str!("view/viewer.css");
/// Most files listed (a folder of frames is a few hundred).
const MAX_LISTED: usize = 20_000;

pub fn run(args: Args) -> Result<()> {
    if !args.dir.is_dir() {
        return Err(Error::invalid(format!("{} is not a folder", args.dir.display())));
    }
    let root = args.dir.canonicalize().map_err(|source| Error::Read { path: args.dir.clone(), source })?;
    let is_material = root.join("material.json").is_file();
    if !root.join("manifest.json").is_file() && !is_material {
        return Err(Error::invalid(format!(
            "{} holds neither manifest.json nor material.json: give a folder patina wrote",
            args.dir.display()
        )));
    }
    let material = if is_material { Some(Material::load(&root)?) } else { None };
    let server = tiny_http::Server::http(("127.0.0.1", args.port))
        .map_err(|e| Error::invalid(format!("cannot listen on 127.0.0.1:{}: {e}", args.port)))?;
    let port = server.server_addr().to_ip().map_or(args.port, |a| a.port());
    let url = format!("http://127.0.0.1:{port}/");
    eprintln!("patina view: serving {} at {url} (Ctrl-C to stop)", args.dir.display());
    ctrlc::set_handler(|| {
        eprintln!("patina view: stopped");
        std::process::exit(0);
    })
    .map_err(|e| Error::Internal(format!("Ctrl-C handler: {e}")))?;
    if !args.no_open {
        open_browser(&url);
    }
    for request in server.incoming_requests() {
        let response = respond(&root, material.as_ref(), request.method(), request.url());
        // A client that hung up is not an error of the viewer.
        let _ = request.respond(response);
    }
    Ok(())
}

/// Open `url` in the desktop's browser, if there is one (failures are silent:
/// the address is printed).
fn open_browser(url: &str) {
    let opener = if cfg!(target_os = "macos") {
        "open"
    } else if cfg!(windows) {
        "explorer"
    } else {
        "xdg-open"
    };
    let _ = std::process::Command::new(opener)
        .arg(url)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn();
}

type Response = tiny_http::Response<std::io::Cursor<Vec<u8>>>;

fn reply(status: u16, content_type: &str, body: Vec<u8>) -> Response {
    let header = tiny_http::Header::from_bytes(&b"Content-Type"[..], content_type.as_bytes()).expect("valid header");
    let nosniff = tiny_http::Header::from_bytes(&b"X-Content-Type-Options"[..], &b"nosniff"[..]).expect("valid header");
    tiny_http::Response::from_data(body).with_status_code(status).with_header(header).with_header(nosniff)
}

fn text(status: u16, message: &str) -> Response {
    reply(status, "text/plain; charset=utf-8", message.as_bytes().to_vec())
}

/// The answer to one request.
fn respond(root: &Path, material: Option<&Material>, method: &tiny_http::Method, url: &str) -> Response {
    if !matches!(method, tiny_http::Method::Get | tiny_http::Method::Head) {
        return text(405, "only GET and HEAD");
    }
    let path = url.split(['?', '#']).next().unwrap_or("/");
    let Some(path) = percent_decode(path) else { return text(400, "bad percent-encoding") };
    if path.split('/').any(|c| c == "..") || path.contains('\\') || path.contains('\0') {
        return text(403, "paths may not leave the folder");
    }
    match path.as_str() {
        "/" | "/index.html" => reply(200, "text/html; charset=utf-8", INDEX_HTML.as_bytes().to_vec()),
        "/viewer.js" => reply(200, "text/javascript; charset=utf-8", VIEWER_JS.as_bytes().to_vec()),
        "/viewer.css" => reply(200, "text/css; charset=utf-8", VIEWER_CSS.as_bytes().to_vec()),
        "/api/listing" => reply(200, "application/json", listing(root, material.is_some()).to_string().into_bytes()),
        "/api/material.json" => match material {
            Some(m) => {
                let (w, h) = m.size();
                let body = json!({
                    "width": w, "height": h, "degree": m.degree, "params": m.params, "encoding": m.encoding,
                    "normal_green_down": patina::stbrdf::render::normal_green_down(m),
                });
                reply(200, "application/json", body.to_string().into_bytes())
            }
            None => text(404, "not a material folder"),
        },
        "/api/material.bin" => match material {
            Some(m) => reply(200, "application/octet-stream", m.coefficients.data().iter().flat_map(|v| v.to_le_bytes()).collect()),
            None => text(404, "not a material folder"),
        },
        p if p.starts_with("/files/") => serve_file(root, &p["/files/".len()..]),
        _ => text(404, "not found"),
    }
}

/// `rel` under `root`, refused unless it stays inside once normalised and
/// its symlinks resolved.
fn serve_file(root: &Path, rel: &str) -> Response {
    let rel_path = Path::new(rel);
    if rel_path.components().any(|c| !matches!(c, Component::Normal(_))) {
        return text(403, "paths may not leave the folder");
    }
    let Ok(full) = root.join(rel_path).canonicalize() else { return text(404, "not found") };
    if !full.starts_with(root) {
        return text(403, "paths may not leave the folder");
    }
    if !full.is_file() {
        return text(404, "not found");
    }
    match std::fs::read(&full) {
        Ok(bytes) => reply(200, content_type(&full), bytes),
        Err(_) => text(404, "not found"),
    }
}

fn content_type(path: &Path) -> &'static str {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("png") => "image/png",
        Some("jpg" | "jpeg") => "image/jpeg",
        Some("gif") => "image/gif",
        Some("json") => "application/json",
        Some("md" | "txt" | "wgsl" | "glsl" | "hlsl" | "shader") => "text/plain; charset=utf-8",
        _ => "application/octet-stream",
    }
}

/// The manifest (parsed, or null) and every file under `root` (relative,
/// '/'-separated, sorted; at most [`MAX_LISTED`]).
fn listing(root: &Path, material: bool) -> serde_json::Value {
    let manifest =
        std::fs::read_to_string(root.join("manifest.json")).ok().and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok());
    let mut files = Vec::new();
    let mut stack = vec![PathBuf::new()];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(root.join(&dir)) else { continue };
        for entry in entries.flatten() {
            let rel = dir.join(entry.file_name());
            match entry.file_type() {
                Ok(t) if t.is_dir() => stack.push(rel),
                Ok(t) if t.is_file() && files.len() < MAX_LISTED => {
                    files.push(rel.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect::<Vec<_>>().join("/"))
                }
                _ => {}
            }
        }
    }
    files.sort();
    json!({ "manifest": manifest, "files": files, "material": material })
}

/// `%XX` decoded (and `+` kept), `None` if malformed or not UTF-8.
fn percent_decode(s: &str) -> Option<String> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn traversal_is_refused_however_it_is_spelled() {
        let root = std::env::temp_dir().join(format!("patina-view-unit-{}", std::process::id()));
        std::fs::create_dir_all(root.join("frames")).unwrap();
        std::fs::write(root.join("frames/a.png"), b"png").unwrap();
        let root = root.canonicalize().unwrap();
        let get = |url: &str| respond(&root, None, &tiny_http::Method::Get, url).status_code().0;
        assert_eq!(get("/files/frames/a.png"), 200);
        for bad in
            ["/../x", "/files/../x", "/files/%2e%2e/x", "/files/frames/%2E%2E/%2E%2E/etc/passwd", "/files//etc/passwd", "/files/..%2fx"]
        {
            let code = get(bad);
            assert!(code == 403 || code == 404, "{bad}: {code}");
        }
        assert_eq!(get("/files/frames/missing.png"), 404);
        assert_eq!(get("/api/material.json"), 404);
        assert_eq!(respond(&root, None, &tiny_http::Method::Post, "/").status_code().0, 405);
        std::fs::remove_dir_all(&root).ok();
    }
}
