//! The dashboard's files, embedded at build time from `gateway/assets/` (build.rs).

/// (path under `assets/`, bytes), sorted by path.
static FILES: &[(&str, &[u8])] = include!(concat!(env!("OUT_DIR"), "/assets.rs"));

/// The answer to a browser without the token (`[http] token_file`): a form that opens the
/// same URL with `?token=`, which the server turns into its cookie and redirects to the URL
/// without it. No script, nothing of the dashboard.
pub const LOGIN_PAGE: &str = "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
<title>handgate: token required</title></head><body>\
<h1>handgate dashboard</h1><p>This dashboard requires its token ([http] token_file).</p>\
<form method=\"get\"><label>Token <input type=\"password\" name=\"token\" autocomplete=\"off\" autofocus></label> \
<button type=\"submit\">Open</button></form></body></html>\n";

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
