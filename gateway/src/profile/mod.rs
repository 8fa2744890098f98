//! Per-robot configuration profiles.
//!
//! A profile is a TOML file describing the DDS participant, logging, the fleet of devices
//! and the fronts that serve them. [`load`] layers, lowest first:
//!
//! 1. the base: the profile named by `--profile` (a file, or a shipped profile compiled into
//!    the binary), or the embedded `default` profile when none is named. A profile file
//!    REPLACES the default entirely (devices and fronts are never merged element-wise);
//!    keys it omits take the struct defaults, not the default profile's values;
//! 2. `HANDGATE_*` environment variables, `__` separating key levels
//!    (`HANDGATE_DDS__DOMAIN=3`, `HANDGATE_LOG__FORMAT=json`); scalar keys only;
//! 3. command-line flags (`--domain`, `--interface`, `--log-format`).
//!
//! Then [`validate()`] checks everything serde cannot. Every error names its origin (file,
//! "embedded default", "environment (VAR)", "command line (--flag)") and key path.
//! See `docs/profiles.md` for the reference.

mod error;
mod render;
mod schema;
mod validate;

#[cfg(test)]
mod tests;

use std::path::{Path, PathBuf};

use figment::providers::{Env, Format, Serialized, Toml};
use figment::value::{Dict, Map, Value};
use figment::{Figment, Metadata, Provider};
use serde::{Deserialize, Serialize};

pub use error::{Issue, KeyPath, Origin, ProfileError, Seg};
pub use render::render_fleet;
pub use schema::*;
pub use validate::{validate, Problem};

/// Profiles compiled into the binary: (name, TOML text), every file of `profiles/` in name
/// order (listed by `gateway/build.rs`). `default` is the base when no profile is named.
pub const SHIPPED: &[(&str, &str)] = include!(concat!(env!("OUT_DIR"), "/shipped_profiles.rs"));

/// Environment variable naming an extra directory searched for `NAME.toml` first.
pub const PROFILE_DIR_ENV: &str = "HANDGATE_PROFILE_DIR";
/// Prefix of the environment variables that override profile keys.
pub const ENV_PREFIX: &str = "HANDGATE_";

/// Flags that override profile keys (the highest layer).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct CliOverrides {
    /// `--domain`: `dds.domain`.
    pub domain: Option<u32>,
    /// `--interface`: `dds.interface`.
    pub interface: Option<String>,
    /// `--log-format`: `log.format`.
    pub log_format: Option<LogFormat>,
    /// `--http-port`: `http.port`.
    pub http_port: Option<u16>,
    /// `--export-domain`: `export.domain`.
    pub export_domain: Option<u32>,
    /// `--export-interface`: `export.interface`.
    pub export_interface: Option<String>,
    /// `--namespace`: `export.namespace`.
    pub namespace: Option<String>,
}

const CLI_METADATA_NAME: &str = "command line";

impl Provider for CliOverrides {
    fn metadata(&self) -> Metadata {
        Metadata::named(CLI_METADATA_NAME)
    }

    fn data(&self) -> Result<Map<figment::Profile, Dict>, figment::Error> {
        let mut root = Dict::new();
        let mut dds = Dict::new();
        if let Some(d) = self.domain {
            dds.insert("domain".into(), Value::from(d));
        }
        if let Some(i) = &self.interface {
            dds.insert("interface".into(), Value::from(i.clone()));
        }
        if !dds.is_empty() {
            root.insert("dds".into(), Value::from(dds));
        }
        if let Some(f) = self.log_format {
            let mut log = Dict::new();
            log.insert("format".into(), Value::from(f.as_str()));
            root.insert("log".into(), Value::from(log));
        }
        let mut export = Dict::new();
        if let Some(d) = self.export_domain {
            export.insert("domain".into(), Value::from(d));
        }
        if let Some(i) = &self.export_interface {
            export.insert("interface".into(), Value::from(i.clone()));
        }
        if let Some(n) = &self.namespace {
            export.insert("namespace".into(), Value::from(n.clone()));
        }
        if !export.is_empty() {
            root.insert("export".into(), Value::from(export));
        }
        if let Some(port) = self.http_port {
            let mut http = Dict::new();
            http.insert("port".into(), Value::from(port));
            root.insert("http".into(), Value::from(http));
        }
        Serialized::defaults(root).data()
    }
}

/// Whether `HANDGATE_*` environment variables take part.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum EnvLayer {
    /// Read the process environment (what the binary does).
    #[default]
    Process,
    /// Ignore the environment.
    Ignore,
}

/// What to load.
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    /// `None`: the embedded default. A name containing `/` or ending in `.toml` is a path;
    /// otherwise `NAME.toml` is looked up in the search directories, then among the
    /// shipped profiles.
    pub profile: Option<String>,
    pub overrides: CliOverrides,
    pub env: EnvLayer,
    /// `None`: `$HANDGATE_PROFILE_DIR` then `./profiles` (see [`default_search_dirs`]).
    pub search_dirs: Option<Vec<PathBuf>>,
}

/// A loaded, valid profile.
#[derive(Debug, Clone, PartialEq)]
pub struct Loaded {
    pub profile: Profile,
    /// Where the base layer came from.
    pub origin: Origin,
}

/// `$HANDGATE_PROFILE_DIR` (if set), then `profiles/` in the working directory.
pub fn default_search_dirs() -> Vec<PathBuf> {
    let mut dirs = Vec::new();
    if let Some(d) = std::env::var_os(PROFILE_DIR_ENV) {
        if !d.is_empty() {
            dirs.push(PathBuf::from(d));
        }
    }
    dirs.push(PathBuf::from("profiles"));
    dirs
}

fn is_path(name: &str) -> bool {
    name.contains('/') || name.ends_with(".toml")
}

/// The base layer: where it came from and its text.
fn resolve_base(name: Option<&str>, dirs: &[PathBuf]) -> Result<(Origin, String), ProfileError> {
    let read = |path: &Path| -> Result<(Origin, String), ProfileError> {
        std::fs::read_to_string(path)
            .map(|t| (Origin::File(path.to_path_buf()), t))
            .map_err(|source| ProfileError::Unreadable {
                path: path.to_path_buf(),
                source,
            })
    };
    let Some(name) = name else {
        return Ok((Origin::Embedded("default".into()), SHIPPED[0].1.to_string()));
    };
    if is_path(name) {
        return read(Path::new(name));
    }
    for dir in dirs {
        let p = dir.join(format!("{name}.toml"));
        if p.is_file() {
            return read(&p);
        }
    }
    if let Some((n, text)) = SHIPPED.iter().find(|(n, _)| *n == name) {
        return Ok((Origin::Embedded((*n).to_string()), (*text).to_string()));
    }
    Err(ProfileError::UnknownProfile {
        name: name.to_string(),
        searched: dirs.to_vec(),
        available: list_profiles(dirs).into_iter().map(|p| p.name).collect(),
    })
}

fn env_provider() -> Env {
    Env::prefixed(ENV_PREFIX).ignore(&["profile_dir"]).split("__")
}

fn env_var_for(key: &KeyPath) -> String {
    let mut s = ENV_PREFIX.to_string();
    let parts: Vec<String> = key
        .0
        .iter()
        .map(|seg| match seg {
            Seg::Key(k) => k.to_uppercase(),
            Seg::Index(i) => i.to_string(),
        })
        .collect();
    s.push_str(&parts.join("__"));
    s
}

fn cli_flag_for(key: &KeyPath) -> Option<String> {
    match key.to_string().as_str() {
        "dds.domain" => Some("--domain".into()),
        "dds.interface" => Some("--interface".into()),
        "log.format" => Some("--log-format".into()),
        "http.port" => Some("--http-port".into()),
        _ => None,
    }
}

/// The origin a layer's values are attributed to, for a value at `key`.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Layer {
    Base,
    Env,
    Cli,
}

fn origin_for(layer: Layer, base: &Origin, key: &KeyPath) -> Origin {
    match layer {
        Layer::Base => base.clone(),
        Layer::Env => Origin::Environment(Some(env_var_for(key))),
        Layer::Cli => Origin::CommandLine(cli_flag_for(key)),
    }
}

/// Turns figment's error chain into issues, all attributed to `layer`.
fn figment_issues(err: figment::Error, layer: Layer, base: &Origin) -> Vec<Issue> {
    use figment::error::Kind;
    err.into_iter()
        .map(|e| {
            let mut key = KeyPath::from_figment(&e.path);
            let message = match &e.kind {
                Kind::UnknownField(field, expected) => {
                    if e.path.last() != Some(field) {
                        key = key.key(field.clone());
                    }
                    if expected.is_empty() {
                        "unknown key".to_string()
                    } else {
                        format!("unknown key (expected one of: {})", expected.join(", "))
                    }
                }
                Kind::MissingField(field) => {
                    if e.path.last().map(String::as_str) != Some(field.as_ref()) {
                        key = key.key(field.to_string());
                    }
                    "missing required key".to_string()
                }
                Kind::Message(m) if e.path.is_empty() && layer == Layer::Base => {
                    format!("not valid TOML: {}", one_line(m))
                }
                other => other.to_string(),
            };
            Issue {
                origin: origin_for(layer, base, &key),
                key,
                message,
            }
        })
        .collect()
}

/// The toml crate's parse errors span several lines (a source excerpt with a caret);
/// keep the text lines and join them so that each error prints as one line.
fn one_line(msg: &str) -> String {
    msg.lines()
        .map(str::trim)
        .filter(|l| {
            !l.is_empty()
                && !l.starts_with('|')
                && !l.starts_with('^')
                && !l.split_once('|').is_some_and(|(n, _)| n.trim().parse::<u64>().is_ok())
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// Which layer set the value at `key` in the merged figment (or, for a key that was left
/// to its default, the nearest enclosing value that was set).
fn layer_of(fig: &Figment, key: &KeyPath) -> Layer {
    let mut tag = None;
    let mut cur: Option<Value> = None;
    for (i, seg) in key.0.iter().enumerate() {
        let next = match (i, seg, &cur) {
            (0, Seg::Key(k), _) => fig.find_value(k).ok(),
            (_, Seg::Key(k), Some(Value::Dict(_, d))) => d.get(k).cloned(),
            (_, Seg::Index(n), Some(Value::Array(_, a))) => a.get(*n).cloned(),
            _ => None,
        };
        match next {
            Some(v) => {
                tag = Some(v.tag());
                cur = Some(v);
            }
            None => break,
        }
    }
    match tag.and_then(|t| fig.get_metadata(t)) {
        Some(m) if m.name == CLI_METADATA_NAME => Layer::Cli,
        Some(m) if m.name.contains("environment") => Layer::Env,
        _ => Layer::Base,
    }
}

/// Parses every table of array `key` (`devices`, `fronts`) of `raw` with `parse` (common
/// keys, then the kind's own), each error naming the table's key path and the layer that
/// set it.
fn tables<T>(
    fig: &Figment,
    key: &str,
    raw: &[Value],
    base: &Origin,
    parse: fn(&Value) -> Result<T, Box<figment::Error>>,
) -> Result<Vec<T>, ProfileError> {
    raw.iter()
        .enumerate()
        .map(|(i, v)| {
            parse(v).map_err(|mut e| {
                e.path.splice(0..0, [key.to_string(), i.to_string()]);
                let layer = layer_of(fig, &KeyPath::root().key(key).index(i));
                ProfileError::Invalid(figment_issues(*e, layer, base))
            })
        })
        .collect()
}

/// Parses every `[[devices]]` table of `raw`, then every `[[fronts]]` table.
fn devices_and_fronts(
    fig: &Figment,
    raw: &RawProfile,
    base: &Origin,
) -> Result<(Vec<DeviceConfig>, Vec<FrontConfig>), ProfileError> {
    Ok((
        tables(fig, "devices", &raw.devices, base, DeviceConfig::from_value)?,
        tables(fig, "fronts", &raw.fronts, base, FrontConfig::from_value)?,
    ))
}

/// Loads, layers and validates a profile. On failure every problem found is reported; a
/// file that does not parse stops before the semantic checks.
pub fn load(opts: &LoadOptions) -> Result<Loaded, ProfileError> {
    let dirs = opts.search_dirs.clone().unwrap_or_else(default_search_dirs);
    let (base, text) = resolve_base(opts.profile.as_deref(), &dirs)?;

    // Extract layer by layer so that a structural error (unknown key, wrong type) is
    // attributed to the layer that introduced it: figment tags a merged table with the
    // layer that created it, not the one that added the bad key.
    let mut fig = Figment::from(Toml::string(&text));
    let raw = fig
        .extract::<RawProfile>()
        .map_err(|e| ProfileError::Invalid(figment_issues(e, Layer::Base, &base)))?;
    // Each device's and front's table: the common keys and its kind's own (structural errors
    // of the base layer before the next layer's).
    devices_and_fronts(&fig, &raw, &base)?;
    if opts.env == EnvLayer::Process {
        fig = fig.merge(env_provider());
        fig.extract::<RawProfile>()
            .map_err(|e| ProfileError::Invalid(figment_issues(e, Layer::Env, &base)))?;
    }
    fig = fig.merge(opts.overrides.clone());
    let raw: RawProfile = fig
        .extract()
        .map_err(|e| ProfileError::Invalid(figment_issues(e, Layer::Cli, &base)))?;
    let (devices, fronts) = devices_and_fronts(&fig, &raw, &base)?;
    let mut profile = raw.into_profile(devices, fronts);

    let issues: Vec<Issue> = validate(&profile)
        .into_iter()
        .map(|(key, message)| Issue {
            origin: origin_for(layer_of(&fig, &key), &base, &key),
            key,
            message,
        })
        .collect();
    if !issues.is_empty() {
        return Err(ProfileError::Invalid(issues));
    }
    if profile.name.is_empty() {
        profile.name = match &base {
            Origin::File(p) => p
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            Origin::Embedded(n) => n.clone(),
            _ => String::new(),
        };
    }
    Ok(Loaded { profile, origin: base })
}

/// A profile `handgate check --list` shows.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ListedProfile {
    pub name: String,
    pub origin: Origin,
    pub description: String,
}

#[derive(Deserialize)]
struct Head {
    #[serde(default)]
    description: String,
}

fn description_of(text: &str) -> String {
    Figment::from(Toml::string(text))
        .extract::<Head>()
        .map(|h| h.description)
        .unwrap_or_else(|_| "(does not parse)".into())
}

/// Every profile `--profile NAME` can name: `*.toml` in the search directories (first
/// found wins), then the shipped profiles not shadowed by a file. Sorted by name.
pub fn list_profiles(dirs: &[PathBuf]) -> Vec<ListedProfile> {
    let mut out: Vec<ListedProfile> = Vec::new();
    for dir in dirs {
        let Ok(entries) = std::fs::read_dir(dir) else {
            continue;
        };
        let mut paths: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "toml") && p.is_file())
            .collect();
        paths.sort();
        for p in paths {
            let Some(name) = p.file_stem().map(|s| s.to_string_lossy().into_owned()) else {
                continue;
            };
            if out.iter().any(|l| l.name == name) {
                continue;
            }
            let description = std::fs::read_to_string(&p)
                .map(|t| description_of(&t))
                .unwrap_or_else(|e| format!("(unreadable: {e})"));
            out.push(ListedProfile {
                name,
                origin: Origin::File(p),
                description,
            });
        }
    }
    for (name, text) in SHIPPED {
        if !out.iter().any(|l| l.name == *name) {
            out.push(ListedProfile {
                name: (*name).to_string(),
                origin: Origin::Embedded((*name).to_string()),
                description: description_of(text),
            });
        }
    }
    out.sort_by(|a, b| a.name.cmp(&b.name));
    out
}
