//! What the gateway's integration tests share.

use std::path::Path;

use handgate_gateway::profile::{load, CliOverrides, EnvLayer, LoadOptions};
use handgate_gateway::resolve::plan;

/// The plan of profile `text`, written to `name` in the test's scratch directory and loaded as
/// `handgate run --profile` would (no environment layer, no search path).
pub fn plan_of(name: &str, text: &str) -> handgate_gateway::plan::Plan {
    let p = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    std::fs::write(&p, text).unwrap();
    let loaded = load(&LoadOptions {
        profile: Some(p.display().to_string()),
        overrides: CliOverrides::default(),
        env: EnvLayer::Ignore,
        search_dirs: Some(vec![]),
    })
    .unwrap_or_else(|e| panic!("{e}"));
    plan(&loaded.profile).unwrap_or_else(|e| panic!("{e:?}"))
}
