//! Errors: every one names where the bad value came from and its key path.

use std::fmt;
use std::path::PathBuf;

/// Where a configuration value came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Origin {
    /// A profile file (as given or found).
    File(PathBuf),
    /// A profile compiled into the binary: `default` prints as "embedded default".
    Embedded(String),
    /// `HANDGATE_*` environment variables; the variable when known.
    Environment(Option<String>),
    /// A command-line flag; the flag when known.
    CommandLine(Option<String>),
}

impl fmt::Display for Origin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Origin::File(p) => write!(f, "{}", p.display()),
            Origin::Embedded(n) if n == "default" => f.write_str("embedded default"),
            Origin::Embedded(n) => write!(f, "embedded profile {n}"),
            Origin::Environment(Some(v)) => write!(f, "environment ({v})"),
            Origin::Environment(None) => f.write_str("environment"),
            Origin::CommandLine(Some(flag)) => write!(f, "command line ({flag})"),
            Origin::CommandLine(None) => f.write_str("command line"),
        }
    }
}

/// One segment of a key path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Seg {
    Key(String),
    Index(usize),
}

/// A key path such as `devices[1].watchdog.timeout_ms`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct KeyPath(pub Vec<Seg>);

impl KeyPath {
    pub fn root() -> Self {
        KeyPath(Vec::new())
    }
    /// `self` extended by a key.
    pub fn key(&self, k: impl Into<String>) -> Self {
        let mut v = self.0.clone();
        v.push(Seg::Key(k.into()));
        KeyPath(v)
    }
    /// `self` extended by an array index.
    pub fn index(&self, i: usize) -> Self {
        let mut v = self.0.clone();
        v.push(Seg::Index(i));
        KeyPath(v)
    }
    /// From figment's error path, where array indices are decimal strings.
    pub fn from_figment(path: &[String]) -> Self {
        KeyPath(
            path.iter()
                .map(|s| match s.parse::<usize>() {
                    Ok(i) => Seg::Index(i),
                    Err(_) => Seg::Key(s.clone()),
                })
                .collect(),
        )
    }
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

impl fmt::Display for KeyPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, s) in self.0.iter().enumerate() {
            match s {
                Seg::Key(k) if i == 0 => f.write_str(k)?,
                Seg::Key(k) => write!(f, ".{k}")?,
                Seg::Index(n) => write!(f, "[{n}]")?,
            }
        }
        Ok(())
    }
}

/// One problem with a profile.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Issue {
    pub origin: Origin,
    pub key: KeyPath,
    pub message: String,
}

impl fmt::Display for Issue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.key.is_empty() {
            write!(f, "{}: {}", self.origin, self.message)
        } else {
            write!(f, "{}: {}: {}", self.origin, self.key, self.message)
        }
    }
}

/// Why a profile could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum ProfileError {
    /// `--profile NAME` matched no file and no shipped profile.
    #[error("unknown profile `{name}` (looked in {}); available profiles: {}", fmt_paths(.searched), .available.join(", "))]
    UnknownProfile {
        name: String,
        searched: Vec<PathBuf>,
        available: Vec<String>,
    },
    /// A profile path that cannot be read.
    #[error("{}: cannot read profile: {source}", .path.display())]
    Unreadable {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The profile parsed (or failed to) with these problems; never empty.
    #[error("{}", fmt_issues(.0))]
    Invalid(Vec<Issue>),
}

impl ProfileError {
    /// One line per problem, as the binary prints them.
    pub fn lines(&self) -> Vec<String> {
        match self {
            ProfileError::Invalid(issues) => issues.iter().map(|i| i.to_string()).collect(),
            other => vec![other.to_string()],
        }
    }
}

fn fmt_paths(p: &[PathBuf]) -> String {
    if p.is_empty() {
        return "no directory".into();
    }
    p.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
}

fn fmt_issues(issues: &[Issue]) -> String {
    issues.iter().map(|i| i.to_string()).collect::<Vec<_>>().join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_paths_print_like_toml_paths() {
        let k = KeyPath::root()
            .key("devices")
            .index(1)
            .key("watchdog")
            .key("timeout_ms");
        assert_eq!(k.to_string(), "devices[1].watchdog.timeout_ms");
        let f = KeyPath::from_figment(&["fronts".into(), "0".into(), "device".into()]);
        assert_eq!(f.to_string(), "fronts[0].device");
    }

    #[test]
    fn issue_names_origin_and_key() {
        let i = Issue {
            origin: Origin::File("profiles/lab.toml".into()),
            key: KeyPath::root().key("dds").key("domain"),
            message: "must be at most 232".into(),
        };
        assert_eq!(i.to_string(), "profiles/lab.toml: dds.domain: must be at most 232");
        assert_eq!(Origin::Embedded("default".into()).to_string(), "embedded default");
    }
}
