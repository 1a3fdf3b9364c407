//! Scenarios from Python: built-in names or TOML files and text, with keyword overrides.
//!
//! An override is a dotted path into the scenario's TOML table and the value to put there:
//! `dt`, `world.size`, `groups.0.max_speed`. A path step into a list takes an index, `*` (every
//! element), or a name: the elements whose `name` or `kind` equals it, so
//! `groups.boids.steering.behaviours.alignment.weight` is the weight of every alignment behaviour
//! of the group named `boids`. `__` separates steps too, for keyword arguments
//! (`groups__boids__max_speed=5`). `index` and `reorder_every` stand for `world.index` and
//! `world.reorder_every`. The overridden table is parsed and validated exactly as a file is;
//! without overrides the text is parsed as the CLI parses it.

use std::path::Path;

use throng::scenario::{self, Scenario};
use throng::{Error, Result};

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
            Source::Builtin(name) => {
                let (_, text) = scenario::BUILTIN
                    .iter()
                    .find(|(n, _)| n == name)
                    .ok_or_else(|| {
                        // The library's own message for an unknown name.
                        scenario::builtin(name).expect_err("the name is not built in")
                    })?;
                Ok((text.to_string(), format!("scenarios/{name}.toml")))
            }
            Source::File(path) => {
                let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
                    path: path.clone(),
                    source,
                })?;
                Ok((text, path.clone()))
            }
            Source::Text(text) => Ok((text.clone(), "<string>".to_string())),
        }
    }
}

/// Parses the scenario and applies the changes.
///
/// # Errors
/// The library's error for a bad file, name or value; [`Error::Invalid`] naming the override for
/// a path that leads nowhere.
pub(crate) fn load(source: &Source, changes: &Changes) -> Result<Scenario> {
    let (text, source_name) = source.text()?;
    let mut s = if changes.overrides.is_empty() {
        Scenario::from_toml(&text, &source_name)?
    } else {
        let mut table: toml::Table = match text.parse() {
            Ok(t) => t,
            // The library reports syntax errors with line and column.
            Err(_) => return Scenario::from_toml(&text, &source_name),
        };
        for (key, value) in &changes.overrides {
            apply(&mut table, key, value.clone())?;
        }
        let text = toml::to_string(&table).map_err(|e| Error::Invalid {
            name: "overrides".into(),
            reason: e.to_string(),
        })?;
        // Lines and columns would point into the rewritten text: the error names the
        // overrides instead.
        Scenario::from_toml(&text, &source_name).map_err(|e| match e {
            Error::Scenario {
                source_name,
                message,
                ..
            } => Error::Scenario {
                source_name: format!(
                    "{source_name} with overrides {}",
                    changes
                        .overrides
                        .iter()
                        .map(|(k, _)| k.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                location: None,
                message,
            },
            other => other,
        })?
    };
    if let Some(seed) = changes.seed {
        s.seed = seed;
    }
    if let Some(n) = changes.agents {
        s = s.with_agents(n)?;
    }
    Ok(s)
}

/// Sets `value` at the dotted `key` of `table` (see the module docs).
fn apply(table: &mut toml::Table, key: &str, value: toml::Value) -> Result<()> {
    let path = key.replace("__", ".");
    let mut steps: Vec<&str> = path.split('.').collect();
    if let ["index" | "reorder_every"] = steps[..] {
        steps.insert(0, "world");
    }
    if steps.iter().any(|s| s.is_empty()) {
        return Err(bad(key, "an empty step in the path".into()));
    }
    let mut root = toml::Value::Table(std::mem::take(table));
    let result = set(&mut root, &steps, &value, key);
    if let toml::Value::Table(t) = root {
        *table = t;
    }
    result
}

fn bad(key: &str, reason: String) -> Error {
    Error::Invalid {
        name: key.to_string(),
        reason,
    }
}

fn set(node: &mut toml::Value, steps: &[&str], value: &toml::Value, key: &str) -> Result<()> {
    let (step, rest) = steps.split_first().expect("paths have at least one step");
    match node {
        toml::Value::Table(t) => {
            if rest.is_empty() {
                t.insert((*step).to_string(), value.clone());
                Ok(())
            } else {
                let child = t
                    .entry((*step).to_string())
                    .or_insert_with(|| toml::Value::Table(toml::Table::new()));
                set(child, rest, value, key)
            }
        }
        toml::Value::Array(items) => {
            let chosen: Vec<usize> = if *step == "*" {
                (0..items.len()).collect()
            } else if let Ok(i) = step.parse::<usize>() {
                if i >= items.len() {
                    return Err(bad(
                        key,
                        format!("index {i} is past the end of a list of {}", items.len()),
                    ));
                }
                vec![i]
            } else {
                let named = |v: &toml::Value| {
                    ["name", "kind"]
                        .iter()
                        .any(|k| v.get(k).and_then(toml::Value::as_str) == Some(step))
                };
                let found: Vec<usize> = (0..items.len()).filter(|&i| named(&items[i])).collect();
                if found.is_empty() {
                    return Err(bad(
                        key,
                        format!("no element of the list is named or of kind `{step}`"),
                    ));
                }
                found
            };
            for i in chosen {
                if rest.is_empty() {
                    items[i] = value.clone();
                } else {
                    set(&mut items[i], rest, value, key)?;
                }
            }
            Ok(())
        }
        _ => Err(bad(
            key,
            format!("`{step}` cannot be looked up in a value that is not a table or a list"),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flock(overrides: &[(&str, toml::Value)]) -> Result<Scenario> {
        let changes = Changes {
            overrides: overrides
                .iter()
                .map(|(k, v)| ((*k).to_string(), v.clone()))
                .collect(),
            ..Changes::default()
        };
        load(&Source::Builtin("flock".into()), &changes)
    }

    #[test]
    fn overrides_reach_lists_by_name_kind_index_and_star() {
        let s = flock(&[
            (
                "groups.boids.steering.behaviours.alignment.weight",
                toml::Value::Float(2.5),
            ),
            ("groups__0__max_speed", toml::Value::Float(3.0)),
            ("groups.*.radius", toml::Value::Float(0.25)),
            ("index", toml::Value::String("kdtree".into())),
            ("dt", toml::Value::Float(0.05)),
        ])
        .unwrap();
        let g = &s.groups[0].params;
        assert_eq!(g.steering.behaviours[1].weight, 2.5);
        assert_eq!(g.steering.behaviours[0].weight, 1.5);
        assert_eq!((g.max_speed, g.radius), (3.0, 0.25));
        assert_eq!(s.world.index, throng::IndexKind::KdTree);
        assert_eq!(s.dt, 0.05);
    }

    #[test]
    fn overrides_that_lead_nowhere_name_the_key() {
        for key in [
            "groups.nobody.max_speed",
            "groups.5.max_speed",
            "dt.x",
            "groups..x",
        ] {
            let e = flock(&[(key, toml::Value::Float(1.0))]).unwrap_err();
            assert!(e.to_string().contains(key), "{key}: {e}");
        }
        let e = flock(&[("groups.0.max_sped", toml::Value::Float(1.0))]).unwrap_err();
        assert!(e.to_string().contains("max_sped"), "{e}");
    }

    #[test]
    fn no_overrides_parse_as_the_cli_does() {
        assert_eq!(
            flock(&[]).unwrap(),
            throng::scenario::builtin("flock").unwrap()
        );
    }
}
