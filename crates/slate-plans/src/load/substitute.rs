//! Placeholders in a `.slate` file's text, replaced before it is parsed: how one file
//! serves every robot of a team (`ROBOT` stands for the robot's name in
//! `examples/demo/robot.slate`). The demo, `slate node`'s config and `slate launch` all
//! substitute through [`Substitution`], so a file means the same wherever it is loaded.

/// The placeholder that stands for a robot's name in per-robot files.
pub const ROBOT_PLACEHOLDER: &str = "ROBOT";

/// Placeholders and their values, applied in order to a file's text.
///
/// Every occurrence of a placeholder is replaced, wherever it is: in names
/// (`ROBOT_pose`), in strings (`"team/ROBOT/exec"`) and in comments. A placeholder is
/// therefore a word chosen not to occur otherwise (upper case by convention); as
/// written, `ROBOT` is itself a valid name, so the file checks unsubstituted too.
///
/// ```
/// use slate_plans::Substitution;
/// let robot = Substitution::robot("r2")?;
/// let text = robot.apply("object ROBOT_pose : Pose owner \"team/ROBOT/nav\";");
/// assert_eq!(text, "object r2_pose : Pose owner \"team/r2/nav\";");
/// assert!(Substitution::new([("", "r2")]).is_err());
/// # Ok::<(), slate_plans::SubstitutionError>(())
/// ```
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Substitution {
    /// (placeholder, value), in the order they are applied.
    pairs: Vec<(String, String)>,
}

/// A substitution that cannot be applied safely.
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SubstitutionError {
    /// A placeholder is not a name (letters, digits and `_`, not starting with a digit):
    /// an empty one would match between every two characters.
    #[error("placeholder {0:?} is not a name: use letters, digits and _, like ROBOT")]
    Placeholder(String),
    /// A value holds a character that would break the file's strings or lines.
    #[error("value {0:?} holds a quote, a backslash or a line break: use a plain name")]
    Value(String),
}

impl Substitution {
    /// Placeholders and values, checked: each placeholder a name, each value free of
    /// quotes, backslashes and line breaks.
    pub fn new<P: Into<String>, V: Into<String>>(
        pairs: impl IntoIterator<Item = (P, V)>,
    ) -> Result<Self, SubstitutionError> {
        let pairs = pairs
            .into_iter()
            .map(|(p, v)| check(p.into(), v.into()))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Substitution { pairs })
    }

    /// [`ROBOT_PLACEHOLDER`] replaced by `robot`.
    pub fn robot(robot: &str) -> Result<Self, SubstitutionError> {
        Substitution::new([(ROBOT_PLACEHOLDER, robot)])
    }

    /// No placeholders: the text as it is.
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }

    /// The (placeholder, value) pairs, in order.
    pub fn pairs(&self) -> impl Iterator<Item = (&str, &str)> {
        self.pairs.iter().map(|(p, v)| (p.as_str(), v.as_str()))
    }

    /// `text` with every placeholder replaced by its value, in order.
    pub fn apply(&self, text: &str) -> String {
        let mut out = text.to_owned();
        for (placeholder, value) in &self.pairs {
            out = out.replace(placeholder.as_str(), value);
        }
        out
    }
}

fn check(placeholder: String, value: String) -> Result<(String, String), SubstitutionError> {
    let name = placeholder
        .chars()
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && placeholder
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_');
    if !name {
        return Err(SubstitutionError::Placeholder(placeholder));
    }
    if value.contains(['"', '\\', '\n', '\r']) {
        return Err(SubstitutionError::Value(value));
    }
    Ok((placeholder, value))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_occurrence_is_replaced_in_names_strings_and_comments() {
        let s = Substitution::robot("r7").unwrap();
        let text = "// robot ROBOT\nobject ROBOT_claim owner \"team/ROBOT/exec\";";
        assert_eq!(
            s.apply(text),
            "// robot r7\nobject r7_claim owner \"team/r7/exec\";"
        );
    }

    #[test]
    fn placeholders_apply_in_order() {
        let s = Substitution::new([("ROBOT", "r1"), ("TEAM", "gsr")]).unwrap();
        assert_eq!(s.apply("TEAM/ROBOT"), "gsr/r1");
        assert!(Substitution::default().is_empty());
        assert_eq!(Substitution::default().apply("ROBOT"), "ROBOT");
    }

    #[test]
    fn an_empty_or_odd_placeholder_or_a_quoted_value_is_refused() {
        for bad in ["", "1ROBOT", "RO BOT", "R-1"] {
            let err = Substitution::new([(bad, "r1")]).unwrap_err();
            assert_eq!(err, SubstitutionError::Placeholder(bad.to_owned()));
        }
        for bad in ["r\"1", "r\\1", "r\n1"] {
            let err = Substitution::robot(bad).unwrap_err();
            assert_eq!(err, SubstitutionError::Value(bad.to_owned()));
        }
    }
}
