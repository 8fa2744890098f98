//! The dashboard's files, embedded at build time from `gateway/assets/` (build.rs).

/// (path under `assets/`, bytes), sorted by path.
static FILES: &[(&str, &[u8])] = include!(concat!(env!("OUT_DIR"), "/assets.rs"));

/// The content type of a file by its extension.
fn content_type(path: &str) -> &'static str {
    match path.rsplit('.').next().unwrap_or("") {
        "html" => "text/html; charset=utf-8",
        "js" | "mjs" => "text/javascript; charset=utf-8",
        "css" => "text/css; charset=utf-8",
        "svg" => "image/svg+xml",
        "png" => "image/png",
        "json" => "application/json",
        _ => "text/plain; charset=utf-8",
    }
}

/// The file served at URL `path`: `/` is `index.html`, `/assets/X` is `X`.
pub fn get(path: &str) -> Option<(&'static str, &'static [u8])> {
    let rel = match path {
        "/" | "/index.html" => "index.html",
        p => p.strip_prefix("/assets/")?,
    };
    if rel.split('/').any(|s| s == ".." || s.is_empty()) {
        return None;
    }
    FILES
        .iter()
        .find(|(p, _)| *p == rel)
        .map(|(p, b)| (content_type(p), *b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_outside_the_assets_are_not_served() {
        assert_eq!(get("/assets/../Cargo.toml"), None);
        assert_eq!(get("/assets//index.html"), None);
        assert_eq!(get("/Cargo.toml"), None);
        assert_eq!(
            content_type("vendor/uPlot.iife.min.js"),
            "text/javascript; charset=utf-8"
        );
    }
}
