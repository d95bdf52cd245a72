//! Source positions and the diagnostics that the lexer, the parser and the checker report.

use std::fmt;

/// A region of the source: byte offsets plus the line and column of its start.
///
/// `line` and `col` are 1-based; `col` counts characters, not bytes. `end` is exclusive, and a
/// span may be empty (`start == end`), for instance "the place where a `;` is missing".
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Span {
    /// Byte offset of the first byte.
    pub start: usize,
    /// Byte offset one past the last byte.
    pub end: usize,
    /// 1-based line of `start`.
    pub line: u32,
    /// 1-based column of `start`, in characters.
    pub col: u32,
}

impl Span {
    /// A span from its four fields.
    pub fn new(start: usize, end: usize, line: u32, col: u32) -> Self {
        Self {
            start,
            end,
            line,
            col,
        }
    }

    /// The span that starts where `self` starts and ends where `last` ends.
    pub fn to(self, last: Span) -> Span {
        Span {
            end: last.end.max(self.start),
            ..self
        }
    }

    /// The empty span just after `self` on its last line (where a missing token would go).
    ///
    /// The column is only exact for single-line spans, which is what the parser uses it for.
    pub fn after(self, source: &str) -> Span {
        let width = source
            .get(self.start..self.end)
            .map_or(0, |s| s.chars().count());
        let width = u32::try_from(width).unwrap_or(u32::MAX);
        Span::new(
            self.end,
            self.end,
            self.line,
            self.col.saturating_add(width),
        )
    }

    /// Number of bytes covered.
    pub fn len(&self) -> usize {
        self.end.saturating_sub(self.start)
    }

    /// Whether the span covers no byte.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// How bad a diagnostic is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Severity {
    /// The source is rejected.
    Error,
    /// The source is accepted, but probably not what was meant.
    Warning,
}

impl fmt::Display for Severity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Severity::Error => "error",
            Severity::Warning => "warning",
        })
    }
}

/// Which stage of the front end found the problem.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Turning characters into tokens (stray characters, unterminated strings, bad numbers).
    Lex,
    /// Turning tokens into a syntax tree.
    Parse,
    /// Resolving names and types in the syntax tree.
    Check,
}

/// One problem found in a source, with the place it was found.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}:{}: {severity}: {message}", span.line, span.col)]
pub struct Diagnostic {
    /// Error or warning.
    pub severity: Severity,
    /// What is wrong, in one line, without position.
    pub message: String,
    /// Where it is wrong.
    pub span: Span,
    /// Which stage found it.
    pub stage: Stage,
}

impl Diagnostic {
    /// An error found by `stage` at `span`.
    pub fn error(stage: Stage, span: Span, message: impl Into<String>) -> Self {
        Self {
            severity: Severity::Error,
            message: message.into(),
            span,
            stage,
        }
    }

    /// A warning found by `stage` at `span`.
    pub fn warning(stage: Stage, span: Span, message: impl Into<String>) -> Self {
        Self {
            severity: Severity::Warning,
            message: message.into(),
            span,
            stage,
        }
    }

    /// Whether this is an error (as opposed to a warning).
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }

    /// The diagnostic as a header line plus the source line with carets under the span.
    ///
    /// ```text
    /// world.slate:3:14: error: expected `;` after attribute declaration, found `}`
    ///   3 | speed: real [m/s]
    ///     |              ^
    /// ```
    /// The line number is right-aligned in a gutter at least three columns wide. There is one
    /// `^` per character of the span on its first line, and at least one. A line longer than
    /// [`MAX_QUOTED_CHARS`] is quoted as a window around the span, `...` marking what is
    /// cut, so a diagnostic stays short whatever the source. Spans outside `source` never
    /// panic: the source lines are then left out.
    pub fn render(&self, file_name: &str, source: &str) -> String {
        let header = format!("{file_name}:{self}");
        let Some(line_text) = nth_line(source, self.span.line) else {
            return header;
        };
        let (line_text, col) = window(line_text, self.span.col);
        let number = self.span.line.to_string();
        let gutter = number.len().max(3);
        let pad = caret_padding(&line_text, col);
        let carets = "^".repeat(self.caret_width(source).min(MAX_QUOTED_CHARS));
        format!(
            "{header}\n{number:>gutter$} | {line_text}\n{:gutter$} | {pad}{carets}",
            ""
        )
    }

    /// Characters of the span on its first line, at least one.
    fn caret_width(&self, source: &str) -> usize {
        let text = source.get(self.span.start..self.span.end).unwrap_or("");
        let first_line = text.split('\n').next().unwrap_or("");
        first_line.trim_end_matches('\r').chars().count().max(1)
    }
}

/// The most characters of a source line a rendered diagnostic quotes.
pub const MAX_QUOTED_CHARS: usize = 120;

/// Characters a cut line keeps before the column it points at.
const CONTEXT_BEFORE: usize = 40;

/// The part of `line` to quote for column `col`, and the column in that part: the line
/// itself if it is short enough, otherwise [`MAX_QUOTED_CHARS`] characters from a little
/// before `col`, with `...` where the line was cut.
fn window(line: &str, col: u32) -> (String, u32) {
    let chars = line.chars().count();
    if chars <= MAX_QUOTED_CHARS {
        return (line.to_owned(), col);
    }
    let at = usize::try_from(col.saturating_sub(1)).unwrap_or(usize::MAX);
    let first = at
        .saturating_sub(CONTEXT_BEFORE)
        .min(chars - MAX_QUOTED_CHARS);
    let kept: String = line.chars().skip(first).take(MAX_QUOTED_CHARS).collect();
    let (head, tail) = (
        if first > 0 { "..." } else { "" },
        if first + MAX_QUOTED_CHARS < chars {
            "..."
        } else {
            ""
        },
    );
    let shift = u32::try_from(first).unwrap_or(u32::MAX);
    let col = col.saturating_sub(shift).saturating_add(head.len() as u32);
    (format!("{head}{kept}{tail}"), col)
}

/// Line `line` (1-based) of `source` without its line terminator.
fn nth_line(source: &str, line: u32) -> Option<&str> {
    let index = usize::try_from(line.checked_sub(1)?).ok()?;
    let text = source.split('\n').nth(index)?;
    Some(text.strip_suffix('\r').unwrap_or(text))
}

/// Whitespace that puts a caret under column `col` of `line_text`, keeping tabs as tabs so that
/// the caret lines up however the terminal expands them.
fn caret_padding(line_text: &str, col: u32) -> String {
    let before = usize::try_from(col.saturating_sub(1)).unwrap_or(usize::MAX);
    let mut pad: String = line_text
        .chars()
        .take(before)
        .map(|c| if c == '\t' { '\t' } else { ' ' })
        .collect();
    let missing = before.saturating_sub(line_text.chars().count());
    pad.extend(std::iter::repeat_n(' ', missing.min(1024)));
    pad
}

/// The most errors reported for one source: past it the rest are noise, and it bounds the
/// output (and the time to render it) whatever the input.
pub(crate) const MAX_ERRORS: usize = 256;

/// All the diagnostics of one source, in source order.
///
/// This is the error type of [`parse`](crate::parse): a source with errors yields every error
/// the parser could find, not just the first.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Diagnostics(pub Vec<Diagnostic>);

impl Diagnostics {
    /// `all`, cut to the first [`MAX_ERRORS`], then one error (at the first left out)
    /// saying how many were found.
    pub(crate) fn at_most_max(mut all: Vec<Diagnostic>) -> Diagnostics {
        let found = all.len();
        if found > MAX_ERRORS {
            let span = all[MAX_ERRORS].span;
            all.truncate(MAX_ERRORS);
            let message = format!("too many errors ({found}); the first {MAX_ERRORS} are shown");
            all.push(Diagnostic::error(Stage::Check, span, message));
        }
        Diagnostics(all)
    }

    /// Every diagnostic rendered with [`Diagnostic::render`], separated by newlines.
    pub fn render(&self, file_name: &str, source: &str) -> String {
        let rendered: Vec<String> = self.0.iter().map(|d| d.render(file_name, source)).collect();
        rendered.join("\n")
    }

    /// Whether any diagnostic is an error.
    pub fn has_errors(&self) -> bool {
        self.0.iter().any(Diagnostic::is_error)
    }

    /// Number of diagnostics.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether there is no diagnostic.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The diagnostics in order.
    pub fn iter(&self) -> std::slice::Iter<'_, Diagnostic> {
        self.0.iter()
    }
}

impl fmt::Display for Diagnostics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, diagnostic) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str("\n")?;
            }
            write!(f, "{diagnostic}")?;
        }
        Ok(())
    }
}

impl std::error::Error for Diagnostics {}

impl From<Vec<Diagnostic>> for Diagnostics {
    fn from(diagnostics: Vec<Diagnostic>) -> Self {
        Self(diagnostics)
    }
}

impl IntoIterator for Diagnostics {
    type Item = Diagnostic;
    type IntoIter = std::vec::IntoIter<Diagnostic>;

    fn into_iter(self) -> Self::IntoIter {
        self.0.into_iter()
    }
}

impl<'a> IntoIterator for &'a Diagnostics {
    type Item = &'a Diagnostic;
    type IntoIter = std::slice::Iter<'a, Diagnostic>;

    fn into_iter(self) -> Self::IntoIter {
        self.0.iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn error_at(start: usize, end: usize, line: u32, col: u32) -> Diagnostic {
        Diagnostic::error(Stage::Parse, Span::new(start, end, line, col), "bad")
    }

    #[test]
    fn render_puts_one_caret_per_character_of_the_span() {
        let source = "a\nlet xyz = 1\n";
        let rendered = error_at(6, 9, 2, 5).render("f.slate", source);
        assert_eq!(
            rendered,
            "f.slate:2:5: error: bad\n  2 | let xyz = 1\n    |     ^^^"
        );
    }

    #[test]
    fn render_shows_one_caret_for_an_empty_span_at_end_of_line() {
        let rendered = error_at(3, 3, 1, 4).render("f", "abc\n");
        assert_eq!(rendered, "f:1:4: error: bad\n  1 | abc\n    |    ^");
    }

    #[test]
    fn render_widens_the_gutter_for_long_line_numbers() {
        let source = "x\n".repeat(1234);
        let rendered = error_at(2466, 2467, 1234, 1).render("f", &source);
        assert_eq!(rendered, "f:1234:1: error: bad\n1234 | x\n     | ^");
    }

    #[test]
    fn render_keeps_tabs_so_the_caret_lines_up() {
        let rendered = error_at(2, 3, 1, 3).render("f", "\t\tx");
        assert_eq!(rendered, "f:1:3: error: bad\n  1 | \t\tx\n    | \t\t^");
    }

    #[test]
    fn render_stops_carets_at_the_end_of_the_first_line() {
        let rendered = error_at(0, 7, 1, 1).render("f", "ab\r\ncd\n");
        assert_eq!(rendered, "f:1:1: error: bad\n  1 | ab\n    | ^^");
    }

    #[test]
    fn render_never_panics_on_spans_outside_or_inside_characters() {
        let source = "é€x";
        for (start, end, line, col) in [(1, 2, 1, 1), (100, 200, 1, 9), (0, 1, 7, 1), (5, 1, 0, 0)]
        {
            let _ = error_at(start, end, line, col).render("f", source);
        }
        assert_eq!(
            error_at(0, 0, 9, 1).render("f", source),
            "f:9:1: error: bad"
        );
    }

    #[test]
    fn render_quotes_a_window_of_a_long_line() {
        let line = format!("{}xyz{}", "a".repeat(10_000), "b".repeat(10_000));
        let rendered = error_at(10_000, 10_003, 1, 10_001).render("f", &line);
        let expected = format!(
            "f:1:10001: error: bad\n  1 | ...{}xyz{}...\n    | {}^^^",
            "a".repeat(CONTEXT_BEFORE),
            "b".repeat(MAX_QUOTED_CHARS - CONTEXT_BEFORE - 3),
            " ".repeat(CONTEXT_BEFORE + 3),
        );
        assert_eq!(rendered, expected);
        let start = error_at(0, 20_003, 1, 1).render("f", &line);
        assert!(
            start.ends_with(&format!("| {}", "^".repeat(MAX_QUOTED_CHARS))),
            "{start}"
        );
        let end = error_at(20_003, 20_003, 1, 20_004).render("f", &line);
        assert!(
            end.ends_with(&format!(
                "{}\n    | {}^",
                "b".repeat(8),
                " ".repeat(MAX_QUOTED_CHARS + 3)
            )),
            "{end}"
        );
    }

    #[test]
    fn diagnostics_render_joins_with_newlines() {
        let all = Diagnostics(vec![error_at(0, 1, 1, 1), error_at(1, 2, 1, 2)]);
        assert_eq!(
            all.render("f", "ab"),
            "f:1:1: error: bad\n  1 | ab\n    | ^\nf:1:2: error: bad\n  1 | ab\n    |  ^"
        );
        assert_eq!(all.to_string(), "1:1: error: bad\n1:2: error: bad");
    }

    #[test]
    fn warnings_are_not_errors() {
        let warning = Diagnostic::warning(Stage::Check, Span::default(), "hmm");
        assert!(!Diagnostics(vec![warning.clone()]).has_errors());
        assert_eq!(warning.to_string(), "0:0: warning: hmm");
    }

    #[test]
    fn span_to_joins_and_after_points_past_the_end() {
        let a = Span::new(2, 4, 1, 3);
        let b = Span::new(7, 9, 2, 1);
        assert_eq!(a.to(b), Span::new(2, 9, 1, 3));
        assert_eq!(a.after("abcdef"), Span::new(4, 4, 1, 5));
    }
}
