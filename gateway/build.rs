//! Embeds every profile of `profiles/` in the binary: writes `$OUT_DIR/shipped_profiles.rs`,
//! the `(name, TOML text)` list `profile::SHIPPED` includes, so adding a profile is adding
//! its file (docs/adapters.md, "Adding a device kind").

use std::fmt::Write as _;
use std::path::PathBuf;

fn main() {
    let dir = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets it")).join("../profiles");
    println!("cargo:rerun-if-changed={}", dir.display());
    let mut names: Vec<(String, PathBuf)> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("reading {}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .map(|p| {
            println!("cargo:rerun-if-changed={}", p.display());
            let name = p.file_stem().expect("a file name").to_string_lossy().into_owned();
            (name, p.canonicalize().expect("an existing file"))
        })
        .collect();
    names.sort();
    let mut out = String::from("&[\n");
    for (name, path) in &names {
        writeln!(out, "    ({name:?}, include_str!({:?})),", path.display().to_string()).unwrap();
    }
    out.push_str("]\n");
    let dest = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets it")).join("shipped_profiles.rs");
    std::fs::write(&dest, out).unwrap_or_else(|e| panic!("writing {}: {e}", dest.display()));
}
