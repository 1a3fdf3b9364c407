//! Scenarios from Python: built-in names or TOML files and text, with keyword overrides.
//!
//! Overrides are the library's dotted paths (`throng::scenario::set_path`): `dt`, `world.size`,
//! `groups.boids.max_speed`, with `__` as a separator too for keyword arguments
//! (`groups__boids__max_speed=5`). The overridden table is parsed and validated exactly as a file
//! is; without overrides the text is parsed as the CLI parses it.

use std::path::Path;

use throng::Result;
use throng::scenario::{self, Scenario};

/// Where a scenario comes from.
#[derive(Debug)]
pub(crate) enum Source {
    /// A built-in scenario's name.
    Builtin(String),
    /// A TOML file.
    File(String),
    /// TOML text.
    Text(String),
}

/// What to change in a scenario before building it.
#[derive(Debug, Default)]
pub(crate) struct Changes {
    /// Total agents, shared among the scalable groups.
    pub agents: Option<usize>,
    /// The seed of all randomness.
    pub seed: Option<u64>,
    /// Dotted paths and their values.
    pub overrides: Vec<(String, toml::Value)>,
}

impl Source {
    /// The built-in scenario of that name, or the file at that path when it ends in `.toml` or
    /// exists (as `throng bench` decides).
    pub(crate) fn name_or_file(name: &str) -> Self {
        if name.ends_with(".toml") || Path::new(name).exists() {
            Source::File(name.to_string())
        } else {
            Source::Builtin(name.to_string())
        }
    }

    /// The TOML text and the name errors and relative map paths refer to.
    fn text(&self) -> Result<(String, String)> {
        match self {
            Source::Builtin(name) => Ok((
                scenario::builtin_text(name)?.to_string(),
                format!("scenarios/{name}.toml"),
            )),
            Source::File(path) => Ok((
                throng::limits::read_text(
                    Path::new(path),
                    throng::limits::MAX_SCENARIO_BYTES,
                    "scenario files",
                )?,
                path.clone(),
            )),
            Source::Text(text) => Ok((text.clone(), "<string>".to_string())),
        }
    }
}

/// Parses the scenario and applies the changes.
///
/// # Errors
/// The library's error for a bad file, name or value; [`throng::Error::Invalid`] naming the override for
/// a path that leads nowhere.
pub(crate) fn load(source: &Source, changes: &Changes) -> Result<Scenario> {
    let (text, source_name) = source.text()?;
    let mut s = Scenario::from_toml_with(&text, &source_name, &changes.overrides)?;
    if let Some(seed) = changes.seed {
        s.seed = seed;
    }
    if let Some(n) = changes.agents {
        s = s.with_agents(n)?;
    }
    Ok(s)
}
