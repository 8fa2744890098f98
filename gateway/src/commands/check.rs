//! `handgate check`: validate a profile and print the resolved fleet, or list the profiles.

use std::process::ExitCode;

use handgate_gateway::cli::{profile_dirs, OverrideArgs};
use handgate_gateway::profile;

/// With `list`: the profiles that can be named. Otherwise `profile` checked and its fleet
/// printed (exit 2 when invalid).
pub fn check(profile: Option<String>, list: bool, overrides: OverrideArgs) -> anyhow::Result<ExitCode> {
    if list {
        for p in profile::list_profiles(&profile_dirs()) {
            println!("{:<16} {:<40} {}", p.name, p.origin.to_string(), p.description);
        }
        return Ok(ExitCode::SUCCESS);
    }
    match super::load(profile, overrides) {
        Ok(l) => print!("{}", profile::render_fleet(&l.profile, &l.origin)),
        Err(code) => return Ok(code),
    }
    Ok(ExitCode::SUCCESS)
}
