//! The built-in scenarios: their TOML texts, embedded in the binary, by name.

use super::spec::Scenario;
use crate::error::{Error, Result};

/// The built-in scenarios: `(name, TOML text)`, in listing order.
pub const BUILTIN: &[(&str, &str)] = &[
    ("seek", include_str!("../../scenarios/seek.toml")),
    ("arrive", include_str!("../../scenarios/arrive.toml")),
    ("wander", include_str!("../../scenarios/wander.toml")),
    ("flock", include_str!("../../scenarios/flock.toml")),
    ("vicsek", include_str!("../../scenarios/vicsek.toml")),
    (
        "antigravity",
        include_str!("../../scenarios/antigravity.toml"),
    ),
    ("pursuit", include_str!("../../scenarios/pursuit.toml")),
    ("obstacles", include_str!("../../scenarios/obstacles.toml")),
    ("path", include_str!("../../scenarios/path.toml")),
    ("leader", include_str!("../../scenarios/leader.toml")),
    ("formation", include_str!("../../scenarios/formation.toml")),
    ("fields", include_str!("../../scenarios/fields.toml")),
    (
        "fields-large",
        include_str!("../../scenarios/fields-large.toml"),
    ),
    (
        "fields-walkers",
        include_str!("../../scenarios/fields-walkers.toml"),
    ),
    ("circle", include_str!("../../scenarios/circle.toml")),
    ("blocks", include_str!("../../scenarios/blocks.toml")),
    ("crossing", include_str!("../../scenarios/crossing.toml")),
    (
        "evacuation",
        include_str!("../../scenarios/evacuation.toml"),
    ),
    ("corridor", include_str!("../../scenarios/corridor.toml")),
    (
        "bottleneck",
        include_str!("../../scenarios/bottleneck.toml"),
    ),
    ("city", include_str!("../../scenarios/city.toml")),
    ("concourse", include_str!("../../scenarios/concourse.toml")),
];

/// The names of the built-in scenarios.
#[must_use]
pub fn builtin_names() -> Vec<&'static str> {
    BUILTIN.iter().map(|(n, _)| *n).collect()
}

/// The TOML text of the built-in scenario `name`, as the repository's `scenarios/` folder has it.
///
/// # Errors
/// [`Error::Scenario`] when no built-in scenario has that name.
pub fn builtin_text(name: &str) -> Result<&'static str> {
    BUILTIN
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, text)| *text)
        .ok_or_else(|| Error::Scenario {
            source_name: name.to_string(),
            location: None,
            message: format!(
                "unknown scenario (built-in scenarios: {})",
                builtin_names().join(", ")
            ),
        })
}

/// Parses the built-in scenario `name`.
///
/// # Errors
/// [`Error::Scenario`] when no built-in scenario has that name.
pub fn builtin(name: &str) -> Result<Scenario> {
    Scenario::from_toml(builtin_text(name)?, &format!("scenarios/{name}.toml"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_parses_and_builds() {
        for name in builtin_names() {
            let s = builtin(name).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(s.name, name);
            let w = s
                .with_agents(50)
                .unwrap()
                .build()
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(!w.is_empty());
        }
    }
}
