//! Reading a scenario from TOML text or a file: the parse, the checks that need the table as
//! written (the ceiling of every number, pedestrian tables of the model the group uses), then
//! [`Scenario::validate`].
//!
//! Invariant: every error names the source (file name), with line and column where the TOML
//! parser knows them; a scenario that parses has been validated whole.

use std::path::Path;

use crate::error::{Error, Result};

use super::Scenario;

/// Checks that every number of a parsed scenario except a `seed` has a magnitude of at most
/// [`MAX_NUMBER`](crate::limits::MAX_NUMBER); the error names the key.
fn check_numbers(table: &toml::Table, prefix: &str) -> std::result::Result<(), String> {
    fn walk(v: &toml::Value, key: &str) -> std::result::Result<(), String> {
        let max = crate::limits::MAX_NUMBER;
        let over = |shown: String| {
            Err(format!(
                "{key} = {shown} lies beyond 1e18, the ceiling of every number in a scenario file"
            ))
        };
        match v {
            toml::Value::Float(f) if f.is_finite() && f.abs() > max => over(f.to_string()),
            toml::Value::Integer(i) if (*i as f64).abs() > max && !key.ends_with("seed") => {
                over(i.to_string())
            }
            toml::Value::Array(a) => a
                .iter()
                .enumerate()
                .try_for_each(|(k, v)| walk(v, &format!("{key}[{k}]"))),
            toml::Value::Table(t) => check_numbers(t, key),
            _ => Ok(()),
        }
    }
    table.iter().try_for_each(|(k, v)| {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        walk(v, &key)
    })
}

/// Checks that no group's `pedestrian` table holds the parameters of a model the group does
/// not use (a `social_force` table under `model = "cfsm"`, the default, was silently ignored);
/// the error names the key. Only the file as written is checked, so `--pedestrian-model` may
/// still switch a group to the other model's defaults.
fn check_model_tables(table: &toml::Table) -> std::result::Result<(), String> {
    let Some(groups) = table.get("groups").and_then(toml::Value::as_array) else {
        return Ok(());
    };
    for (i, g) in groups.iter().enumerate() {
        let Some(p) = g.get("pedestrian").and_then(toml::Value::as_table) else {
            continue;
        };
        let model = p
            .get("model")
            .and_then(toml::Value::as_str)
            .and_then(crate::ped::Model::parse)
            .unwrap_or_default();
        for other in crate::ped::Model::ALL {
            if other != model && p.contains_key(other.name()) {
                return Err(format!(
                    "groups[{i}].pedestrian.{}: the group's pedestrian model is {}, which does not read this table (set `model = \"{}\"` or remove the table)",
                    other.name(),
                    model.name(),
                    other.name()
                ));
            }
        }
    }
    Ok(())
}

/// Byte offset to 1-based (line, column).
pub(crate) fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before
        .rfind('\n')
        .map_or(before.len(), |nl| before.len() - nl - 1)
        + 1;
    (line, col)
}

impl Scenario {
    /// Parses a scenario from TOML text; `source_name` names it in errors.
    ///
    /// # Errors
    /// [`Error::Scenario`] with line and column for a syntax error, an unknown key or a bad
    /// value; the variant naming the parameter for an out-of-range number.
    pub fn from_toml(text: &str, source_name: &str) -> Result<Self> {
        let mut s: Scenario = toml::from_str(text).map_err(|e| Error::Scenario {
            source_name: source_name.to_string(),
            location: e.span().map(|sp| line_col(text, sp.start)),
            message: e.message().trim().to_string(),
        })?;
        if let Ok(table) = toml::from_str::<toml::Table>(text) {
            check_numbers(&table, "")
                .and_then(|()| check_model_tables(&table))
                .map_err(|message| Error::Scenario {
                    source_name: source_name.to_string(),
                    location: None,
                    message,
                })?;
        }
        if let Some(f) = &mut s.field {
            f.resolve_paths(source_name);
        }
        if s.name.is_empty() {
            s.name = Path::new(source_name)
                .file_stem()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_default();
        }
        s.validate().map_err(|e| match e {
            Error::Scenario { .. } => e,
            other => Error::Scenario {
                source_name: source_name.to_string(),
                location: None,
                message: other.to_string(),
            },
        })?;
        Ok(s)
    }

    /// Reads and parses a scenario file of at most
    /// [`MAX_SCENARIO_BYTES`](crate::limits::MAX_SCENARIO_BYTES) (larger files are refused
    /// before they are read).
    ///
    /// # Errors
    /// [`Error::Io`] when the file cannot be read or is too large, otherwise as
    /// [`Scenario::from_toml`].
    pub fn load(path: &Path) -> Result<Self> {
        let text =
            crate::limits::read_text(path, crate::limits::MAX_SCENARIO_BYTES, "scenario files")?;
        Self::from_toml(&text, &path.display().to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMALL: &str = r#"
name = "t"
[world]
kind = "torus"
size = [50, 50]
[[groups]]
count = 10
max_speed = 3
steering = { behaviours = [{ kind = "wander", weight = 1 }] }
"#;

    #[test]
    fn parses_and_scales() {
        let s = Scenario::from_toml(SMALL, "t.toml").unwrap();
        assert_eq!(s.agent_count(), 10);
        let s = s.with_agents(123).unwrap();
        assert_eq!(s.build().unwrap().len(), 123);
    }

    #[test]
    fn unknown_keys_name_line_and_column() {
        let text = SMALL.replace("max_speed = 3", "max_sped = 3");
        let err = Scenario::from_toml(&text, "t.toml").unwrap_err();
        let msg = err.to_string();
        assert!(msg.starts_with("t.toml:"), "{msg}");
        assert!(msg.contains("max_sped"), "{msg}");
        match err {
            Error::Scenario {
                location: Some((line, _)),
                ..
            } => assert!(line >= 5, "line {line}"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn bad_values_are_errors() {
        let text = SMALL.replace("max_speed = 3", "max_speed = -3");
        let msg = Scenario::from_toml(&text, "t.toml")
            .unwrap_err()
            .to_string();
        assert!(msg.contains("max_speed"), "{msg}");
    }

    #[test]
    fn line_col_counts_from_one() {
        assert_eq!(line_col("ab\ncd", 0), (1, 1));
        assert_eq!(line_col("ab\ncd", 4), (2, 2));
    }
}
