//! Reading a TOML table key by key, so that every error names the file, the full key
//! and what was expected, and keys nobody asked for are errors.

use std::time::Duration;

use toml::{Table, Value};

use crate::error::ConfigError;

/// One table of a config file, consumed key by key.
pub(crate) struct Fields {
    file: String,
    /// `zenoh.` for the `[zenoh]` table, empty at the top.
    prefix: String,
    table: Table,
    known: &'static [&'static str],
}

impl Fields {
    /// The top table of `file`; `known` lists its keys (for the unknown-key message).
    pub fn new(file: &str, table: Table, known: &'static [&'static str]) -> Self {
        Fields {
            file: file.to_owned(),
            prefix: String::new(),
            table,
            known,
        }
    }

    /// The full name of `key` in this table (`zenoh.listen`).
    pub fn path(&self, key: &str) -> String {
        format!("{}{key}", self.prefix)
    }

    /// An error about `key`: what was expected, and what was found.
    pub fn invalid(&self, key: &str, expected: &str, found: &str) -> ConfigError {
        ConfigError::Invalid {
            file: self.file.clone(),
            key: self.path(key),
            expected: expected.to_owned(),
            found: found.to_owned(),
        }
    }

    fn take(&mut self, key: &str) -> Option<Value> {
        self.table.remove(key)
    }

    /// A required string.
    pub fn required_str(&mut self, key: &str, expected: &str) -> Result<String, ConfigError> {
        match self.take(key) {
            Some(Value::String(s)) => Ok(s),
            Some(v) => Err(self.invalid(key, expected, &describe(&v))),
            None => Err(ConfigError::Missing {
                file: self.file.clone(),
                key: self.path(key),
                expected: expected.to_owned(),
            }),
        }
    }

    /// An optional string.
    pub fn str(&mut self, key: &str, expected: &str) -> Result<Option<String>, ConfigError> {
        match self.take(key) {
            Some(Value::String(s)) => Ok(Some(s)),
            Some(v) => Err(self.invalid(key, expected, &describe(&v))),
            None => Ok(None),
        }
    }

    /// An optional list of strings.
    pub fn strings(
        &mut self,
        key: &str,
        expected: &str,
    ) -> Result<Option<Vec<String>>, ConfigError> {
        let Some(v) = self.take(key) else {
            return Ok(None);
        };
        let Value::Array(items) = v else {
            return Err(self.invalid(key, expected, &describe(&v)));
        };
        items
            .into_iter()
            .map(|item| match item {
                Value::String(s) => Ok(s),
                other => Err(self.invalid(key, expected, &describe(&other))),
            })
            .collect::<Result<Vec<_>, _>>()
            .map(Some)
    }

    /// An optional list of any values (the caller reads each item).
    pub fn list(&mut self, key: &str, expected: &str) -> Result<Option<Vec<Value>>, ConfigError> {
        match self.take(key) {
            Some(Value::Array(items)) => Ok(Some(items)),
            Some(v) => Err(self.invalid(key, expected, &describe(&v))),
            None => Ok(None),
        }
    }

    /// An optional boolean.
    pub fn bool(&mut self, key: &str) -> Result<Option<bool>, ConfigError> {
        match self.take(key) {
            Some(Value::Boolean(b)) => Ok(Some(b)),
            Some(v) => Err(self.invalid(key, "true or false", &describe(&v))),
            None => Ok(None),
        }
    }

    /// An optional positive integer.
    pub fn count(&mut self, key: &str) -> Result<Option<usize>, ConfigError> {
        match self.take(key) {
            Some(Value::Integer(n)) if n > 0 => Ok(usize::try_from(n).ok()),
            Some(v) => Err(self.invalid(key, "a positive integer", &describe(&v))),
            None => Ok(None),
        }
    }

    /// An optional integer from `min` to `max`.
    pub fn integer_in(
        &mut self,
        key: &str,
        min: i64,
        max: i64,
    ) -> Result<Option<i64>, ConfigError> {
        match self.take(key) {
            Some(Value::Integer(n)) if (min..=max).contains(&n) => Ok(Some(n)),
            Some(v) => {
                let expected = format!("an integer from {min} to {max}");
                Err(self.invalid(key, &expected, &describe(&v)))
            }
            None => Ok(None),
        }
    }

    /// An optional duration written `"250ms"`, `"1.5s"` or `"2min"`.
    pub fn duration(&mut self, key: &str) -> Result<Option<Duration>, ConfigError> {
        const EXPECTED: &str = "a duration like \"250ms\", \"1.5s\" or \"2min\"";
        match self.take(key) {
            Some(Value::String(s)) => parse_duration(&s)
                .map(Some)
                .ok_or_else(|| self.invalid(key, EXPECTED, &format!("{s:?}"))),
            Some(v) => Err(self.invalid(key, EXPECTED, &describe(&v))),
            None => Ok(None),
        }
    }

    /// An optional sub-table whose keys are the user's (not a fixed set), read key by
    /// key with [`Fields::keys`].
    pub fn free_table(&mut self, key: &str) -> Result<Option<Fields>, ConfigError> {
        match self.take(key) {
            Some(Value::Table(table)) => Ok(Some(Fields {
                file: self.file.clone(),
                prefix: format!("{}{key}.", self.prefix),
                table,
                known: &[],
            })),
            Some(v) => Err(self.invalid(key, "a table", &describe(&v))),
            None => Ok(None),
        }
    }

    /// The keys not read yet, in order.
    pub fn keys(&self) -> Vec<String> {
        self.table.keys().cloned().collect()
    }

    /// An optional sub-table, read with its own known keys.
    pub fn table(
        &mut self,
        key: &str,
        known: &'static [&'static str],
    ) -> Result<Option<Fields>, ConfigError> {
        match self.take(key) {
            Some(Value::Table(table)) => Ok(Some(Fields {
                file: self.file.clone(),
                prefix: format!("{}{key}.", self.prefix),
                table,
                known,
            })),
            Some(v) => Err(self.invalid(key, "a table", &describe(&v))),
            None => Ok(None),
        }
    }

    /// Every key was read: a key left over is unknown.
    pub fn finish(self) -> Result<(), ConfigError> {
        match self.table.keys().next() {
            None => Ok(()),
            Some(key) => Err(ConfigError::Unknown {
                file: self.file.clone(),
                key: self.path(key),
                known: self
                    .known
                    .iter()
                    .map(|k| format!("{}{k}", self.prefix))
                    .collect::<Vec<_>>()
                    .join(", "),
            }),
        }
    }
}

/// What a value is, for error messages: its type, and the value if short.
pub(crate) fn describe(v: &Value) -> String {
    match v {
        Value::String(s) if s.len() <= 40 => format!("string {s:?}"),
        Value::Integer(n) => format!("integer {n}"),
        Value::Float(x) => format!("float {x}"),
        Value::Boolean(b) => format!("boolean {b}"),
        Value::Array(_) => "a list".to_owned(),
        Value::Table(_) => "a table".to_owned(),
        other => other.type_str().to_owned(),
    }
}

/// `"250ms"`, `"1.5s"`, `"2min"`: a non-negative finite number and a unit (the form of
/// every duration in a config).
pub fn parse_duration(text: &str) -> Option<Duration> {
    let text = text.trim();
    let split = text.find(|c: char| c.is_ascii_alphabetic())?;
    let (number, unit) = text.split_at(split);
    let n: f64 = number.trim().parse().ok()?;
    let scale = match unit {
        "ms" => 1e-3,
        "s" => 1.0,
        "min" => 60.0,
        _ => return None,
    };
    Duration::try_from_secs_f64(n * scale).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_need_a_unit() {
        assert_eq!(parse_duration("250ms"), Some(Duration::from_millis(250)));
        assert_eq!(parse_duration("1.5s"), Some(Duration::from_millis(1500)));
        assert_eq!(parse_duration("2min"), Some(Duration::from_secs(120)));
        for bad in ["", "5", "s", "-1s", "1h", "1 parsec", "nan s"] {
            assert_eq!(parse_duration(bad), None, "{bad}");
        }
    }
}
