//! The lexer: characters to tokens, on demand.
//!
//! The parser pulls one token at a time, because the text of a unit (`[m/s^2]`) is raw and only
//! the parser knows when it is reading one (see [`Lexer::unit_text`]). Lexical errors are
//! collected in the lexer and surface as a [`TokenKind::Error`] token, which the parser treats as
//! "already reported" so that one bad character never causes a second, parse-stage error.

use crate::diagnostic::{Diagnostic, Span, Stage};

/// Reserved words. Attribute names may still be spelt like one (see the parser's member names).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Keyword {
    Class,
    Object,
    Plan,
    On,
    Write,
    Read,
    Set,
    Report,
    Send,
    Create,
    Delete,
    Any,
    All,
    Count,
    Where,
    By,
    Desc,
    And,
    Or,
    Not,
    True,
    False,
    None,
    In,
    Step,
    Derived,
    Merge,
    Every,
    Heartbeat,
    Deadband,
    Context,
    Owner,
    Accuracy,
    Confidence,
    Initiation,
    Trigger,
    Termination,
    Action,
    To,
    SelfKw,
    Link,
}

/// Every keyword with its spelling, in the order of the language reference.
pub(crate) const KEYWORDS: [(&str, Keyword); 41] = [
    ("class", Keyword::Class),
    ("object", Keyword::Object),
    ("plan", Keyword::Plan),
    ("on", Keyword::On),
    ("write", Keyword::Write),
    ("read", Keyword::Read),
    ("set", Keyword::Set),
    ("report", Keyword::Report),
    ("send", Keyword::Send),
    ("create", Keyword::Create),
    ("delete", Keyword::Delete),
    ("any", Keyword::Any),
    ("all", Keyword::All),
    ("count", Keyword::Count),
    ("where", Keyword::Where),
    ("by", Keyword::By),
    ("desc", Keyword::Desc),
    ("and", Keyword::And),
    ("or", Keyword::Or),
    ("not", Keyword::Not),
    ("true", Keyword::True),
    ("false", Keyword::False),
    ("none", Keyword::None),
    ("in", Keyword::In),
    ("step", Keyword::Step),
    ("derived", Keyword::Derived),
    ("merge", Keyword::Merge),
    ("every", Keyword::Every),
    ("heartbeat", Keyword::Heartbeat),
    ("deadband", Keyword::Deadband),
    ("context", Keyword::Context),
    ("owner", Keyword::Owner),
    ("accuracy", Keyword::Accuracy),
    ("confidence", Keyword::Confidence),
    ("initiation", Keyword::Initiation),
    ("trigger", Keyword::Trigger),
    ("termination", Keyword::Termination),
    ("action", Keyword::Action),
    ("to", Keyword::To),
    ("self", Keyword::SelfKw),
    ("link", Keyword::Link),
];

impl Keyword {
    /// The keyword spelt `word`, if any.
    pub(crate) fn from_word(word: &str) -> Option<Keyword> {
        KEYWORDS
            .iter()
            .find(|(text, _)| *text == word)
            .map(|&(_, kw)| kw)
    }

    /// How the keyword is spelt.
    pub(crate) fn as_str(self) -> &'static str {
        KEYWORDS
            .iter()
            .find(|(_, kw)| *kw == self)
            .map_or("?", |&(text, _)| text)
    }
}

/// What a token is; literals carry their decoded value.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum TokenKind {
    Ident(String),
    Keyword(Keyword),
    Int(i64),
    Real(f64),
    /// A duration literal (`250ms`), in seconds.
    Duration(f64),
    /// A string literal, escapes decoded.
    Str(String),
    LBrace,
    RBrace,
    LParen,
    RParen,
    LBracket,
    RBracket,
    Comma,
    Semi,
    Colon,
    Dot,
    DotDot,
    Assign,
    EqEq,
    NotEq,
    Lt,
    Le,
    Gt,
    Ge,
    Plus,
    Minus,
    Star,
    Slash,
    Percent,
    /// Something the lexer already reported; the parser stays silent about it.
    Error,
    Eof,
}

/// A token and where it is.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Token {
    pub(crate) kind: TokenKind,
    pub(crate) span: Span,
}

/// Duration suffixes and their length in seconds.
const DURATION_UNITS: [(&str, f64); 5] = [
    ("us", 1e-6),
    ("ms", 1e-3),
    ("s", 1.0),
    ("min", 60.0),
    ("h", 3600.0),
];

/// A position in the source: byte offset, line and column.
#[derive(Debug, Clone, Copy)]
struct Cursor {
    pos: usize,
    line: u32,
    col: u32,
}

/// Turns a source into tokens, one [`Lexer::next_token`] at a time.
pub(crate) struct Lexer<'s> {
    src: &'s str,
    at: Cursor,
    diagnostics: Vec<Diagnostic>,
}

impl<'s> Lexer<'s> {
    pub(crate) fn new(src: &'s str) -> Self {
        Self {
            src,
            at: Cursor {
                pos: 0,
                line: 1,
                col: 1,
            },
            diagnostics: Vec::new(),
        }
    }

    /// The errors found so far.
    pub(crate) fn into_diagnostics(self) -> Vec<Diagnostic> {
        self.diagnostics
    }

    /// The next token; [`TokenKind::Eof`] forever once the source is exhausted.
    pub(crate) fn next_token(&mut self) -> Token {
        self.skip_trivia();
        let start = self.at;
        let Some(c) = self.peek() else {
            return Token {
                kind: TokenKind::Eof,
                span: self.span_from(start),
            };
        };
        let kind = match c {
            'a'..='z' | 'A'..='Z' | '_' => self.word(),
            '0'..='9' => self.number(start),
            '"' => self.string(start),
            _ => self.punctuation(start),
        };
        Token {
            kind,
            span: self.span_from(start),
        }
    }

    /// The token after the current position, without consuming it or reporting its errors.
    pub(crate) fn peek_token(&self) -> Token {
        Lexer {
            src: self.src,
            at: self.at,
            diagnostics: Vec::new(),
        }
        .next_token()
    }

    /// Reads the raw text of a unit after its `[`, up to and including the closing `]`.
    ///
    /// Returns the trimmed text and the span of the text and the bracket; a unit must close on
    /// its own line.
    pub(crate) fn unit_text(&mut self) -> Result<(String, Span), Span> {
        let start = self.at;
        while let Some(c) = self.peek() {
            if c == ']' {
                let text = self.src[start.pos..self.at.pos].trim().to_owned();
                self.bump();
                return Ok((text, self.span_from(start)));
            }
            if c == '\n' {
                break;
            }
            self.bump();
        }
        Err(self.span_from(start))
    }

    fn peek(&self) -> Option<char> {
        self.src[self.at.pos..].chars().next()
    }

    fn peek_second(&self) -> Option<char> {
        self.src[self.at.pos..].chars().nth(1)
    }

    fn bump(&mut self) -> Option<char> {
        let c = self.peek()?;
        self.at.pos += c.len_utf8();
        if c == '\n' {
            self.at.line = self.at.line.saturating_add(1);
            self.at.col = 1;
        } else {
            self.at.col = self.at.col.saturating_add(1);
        }
        Some(c)
    }

    fn bump_while(&mut self, keep: impl Fn(char) -> bool) {
        while self.peek().is_some_and(&keep) {
            self.bump();
        }
    }

    fn span_from(&self, start: Cursor) -> Span {
        Span::new(start.pos, self.at.pos, start.line, start.col)
    }

    fn error(&mut self, span: Span, message: impl Into<String>) -> TokenKind {
        self.diagnostics
            .push(Diagnostic::error(Stage::Lex, span, message));
        TokenKind::Error
    }

    /// Skips whitespace and `//` comments.
    fn skip_trivia(&mut self) {
        loop {
            match self.peek() {
                Some(c) if c.is_whitespace() => {
                    self.bump();
                }
                Some('/') if self.peek_second() == Some('/') => self.bump_while(|c| c != '\n'),
                _ => return,
            }
        }
    }

    fn word(&mut self) -> TokenKind {
        let start = self.at.pos;
        self.bump_while(is_word_char);
        let word = &self.src[start..self.at.pos];
        Keyword::from_word(word)
            .map_or_else(|| TokenKind::Ident(word.to_owned()), TokenKind::Keyword)
    }

    /// Integer, real (`2.5`, `1e-3`) or duration (`250ms`, `1.5s`).
    fn number(&mut self, start: Cursor) -> TokenKind {
        self.bump_while(|c| c.is_ascii_digit());
        let mut is_real = self.fraction();
        is_real |= self.exponent();
        let digits_end = self.at.pos;
        let digits = &self.src[start.pos..digits_end];
        if self.peek().is_some_and(is_word_char) {
            self.bump_while(is_word_char);
            let suffix = &self.src[digits_end..self.at.pos];
            return self.duration(start, digits, suffix);
        }
        if is_real {
            self.real(start, digits)
        } else {
            self.int(start, digits)
        }
    }

    /// Consumes `.digits` if present (but not `..`, the range operator).
    fn fraction(&mut self) -> bool {
        let is_fraction =
            self.peek() == Some('.') && self.peek_second().is_some_and(|c| c.is_ascii_digit());
        if is_fraction {
            self.bump();
            self.bump_while(|c| c.is_ascii_digit());
        }
        is_fraction
    }

    /// Consumes `e[+-]digits` if present.
    fn exponent(&mut self) -> bool {
        let rest = &self.src[self.at.pos..];
        let Some(after_e) = rest.strip_prefix(['e', 'E']) else {
            return false;
        };
        let unsigned = after_e.strip_prefix(['+', '-']).unwrap_or(after_e);
        if !unsigned.starts_with(|c: char| c.is_ascii_digit()) {
            return false;
        }
        self.bump();
        if after_e.len() != unsigned.len() {
            self.bump();
        }
        self.bump_while(|c| c.is_ascii_digit());
        true
    }

    fn int(&mut self, start: Cursor, digits: &str) -> TokenKind {
        match digits.parse::<i64>() {
            Ok(value) => TokenKind::Int(value),
            Err(_) => self.error(
                self.span_from(start),
                format!(
                    "integer literal `{digits}` is too large (the maximum is {})",
                    i64::MAX
                ),
            ),
        }
    }

    fn real(&mut self, start: Cursor, digits: &str) -> TokenKind {
        match digits.parse::<f64>() {
            Ok(value) if value.is_finite() => TokenKind::Real(value),
            _ => self.error(
                self.span_from(start),
                format!("real literal `{digits}` is out of range"),
            ),
        }
    }

    fn duration(&mut self, start: Cursor, digits: &str, suffix: &str) -> TokenKind {
        let span = self.span_from(start);
        let Some(&(_, seconds)) = DURATION_UNITS.iter().find(|(unit, _)| *unit == suffix) else {
            return self.error(
                span,
                format!("unknown duration unit `{suffix}`; use us, ms, s, min or h"),
            );
        };
        match digits.parse::<f64>().map(|v| v * seconds) {
            Ok(value) if value.is_finite() => TokenKind::Duration(value),
            _ => self.error(span, format!("duration `{digits}{suffix}` is out of range")),
        }
    }

    /// A string literal on one line, with `\"`, `\\` and `\n` escapes.
    fn string(&mut self, start: Cursor) -> TokenKind {
        self.bump();
        let mut value = String::new();
        let mut ok = true;
        loop {
            match self.peek() {
                None | Some('\n') => {
                    let span = self.span_from(start);
                    return self.error(span, "unterminated string: add a closing `\"`");
                }
                Some('"') => break,
                Some('\\') => ok &= self.escape(&mut value),
                Some(c) => {
                    value.push(c);
                    self.bump();
                }
            }
        }
        self.bump();
        if ok {
            TokenKind::Str(value)
        } else {
            TokenKind::Error
        }
    }

    /// Decodes one escape into `value`; false (and an error) if it is unknown.
    fn escape(&mut self, value: &mut String) -> bool {
        let start = self.at;
        self.bump();
        let decoded = match self.peek() {
            Some('"') => '"',
            Some('\\') => '\\',
            Some('n') => '\n',
            Some('\n') | None => return true,
            Some(other) => {
                self.bump();
                let span = self.span_from(start);
                self.error(
                    span,
                    format!("unknown escape `\\{other}`; use `\\\"`, `\\\\` or `\\n`"),
                );
                return false;
            }
        };
        self.bump();
        value.push(decoded);
        true
    }

    fn punctuation(&mut self, start: Cursor) -> TokenKind {
        let c = self.bump().unwrap_or_default();
        let next = self.peek();
        let two = |lexer: &mut Self, kind| {
            lexer.bump();
            kind
        };
        match (c, next) {
            ('.', Some('.')) => two(self, TokenKind::DotDot),
            ('=', Some('=')) => two(self, TokenKind::EqEq),
            ('!', Some('=')) => two(self, TokenKind::NotEq),
            ('<', Some('=')) => two(self, TokenKind::Le),
            ('>', Some('=')) => two(self, TokenKind::Ge),
            _ => single_punctuation(c).unwrap_or_else(|| self.stray(start, c)),
        }
    }

    /// Reports a run of characters that start no token, as one error.
    fn stray(&mut self, start: Cursor, first: char) -> TokenKind {
        self.bump_while(|c| !starts_token(c) && !c.is_whitespace());
        let span = self.span_from(start);
        let text = &self.src[span.start..span.end];
        let message = match (first, text.chars().count()) {
            ('&', _) if text.starts_with("&&") => "unexpected `&&`; use `and`".to_owned(),
            ('|', _) if text.starts_with("||") => "unexpected `||`; use `or`".to_owned(),
            ('!', 1) => "unexpected `!`; use `not`".to_owned(),
            (_, 1) => format!("unexpected character `{text}`"),
            _ => format!("unexpected characters `{text}`"),
        };
        self.error(span, message)
    }
}

fn single_punctuation(c: char) -> Option<TokenKind> {
    Some(match c {
        '{' => TokenKind::LBrace,
        '}' => TokenKind::RBrace,
        '(' => TokenKind::LParen,
        ')' => TokenKind::RParen,
        '[' => TokenKind::LBracket,
        ']' => TokenKind::RBracket,
        ',' => TokenKind::Comma,
        ';' => TokenKind::Semi,
        ':' => TokenKind::Colon,
        '.' => TokenKind::Dot,
        '=' => TokenKind::Assign,
        '<' => TokenKind::Lt,
        '>' => TokenKind::Gt,
        '+' => TokenKind::Plus,
        '-' => TokenKind::Minus,
        '*' => TokenKind::Star,
        '/' => TokenKind::Slash,
        '%' => TokenKind::Percent,
        _ => return None,
    })
}

fn is_word_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// Whether `c` can begin a token (used to end a run of stray characters).
fn starts_token(c: char) -> bool {
    is_word_char(c) || c == '"' || single_punctuation(c).is_some()
}

/// Every token of `source` up to and including [`TokenKind::Eof`], and the lexical errors.
#[cfg(test)]
pub(crate) fn tokenize(source: &str) -> (Vec<Token>, Vec<Diagnostic>) {
    let mut lexer = Lexer::new(source);
    let mut tokens = Vec::new();
    loop {
        let token = lexer.next_token();
        let done = token.kind == TokenKind::Eof;
        tokens.push(token);
        if done {
            return (tokens, lexer.into_diagnostics());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::TokenKind::*;
    use super::*;

    fn kinds(source: &str) -> Vec<TokenKind> {
        let (tokens, diagnostics) = tokenize(source);
        assert!(diagnostics.is_empty(), "unexpected errors: {diagnostics:?}");
        tokens.into_iter().map(|t| t.kind).collect()
    }

    fn only_error(source: &str) -> Diagnostic {
        let (_, diagnostics) = tokenize(source);
        assert_eq!(diagnostics.len(), 1, "{diagnostics:?}");
        diagnostics
            .into_iter()
            .next()
            .unwrap_or_else(|| unreachable!())
    }

    #[test]
    fn lexes_every_punctuation_token() {
        assert_eq!(
            kinds("{ } ( ) [ ] , ; : . .. = == != < <= > >= + - * / %"),
            vec![
                LBrace, RBrace, LParen, RParen, LBracket, RBracket, Comma, Semi, Colon, Dot,
                DotDot, Assign, EqEq, NotEq, Lt, Le, Gt, Ge, Plus, Minus, Star, Slash, Percent,
                Eof
            ]
        );
    }

    #[test]
    fn lexes_every_keyword_and_keeps_other_words_as_identifiers() {
        for (word, keyword) in KEYWORDS {
            assert_eq!(kinds(word), vec![Keyword(keyword), Eof], "{word}");
            assert_eq!(keyword.as_str(), word);
        }
        assert_eq!(
            kinds("speed _x A9 on_accuracy selfish"),
            ["speed", "_x", "A9", "on_accuracy", "selfish"]
                .map(|w| Ident(w.to_owned()))
                .into_iter()
                .chain([Eof])
                .collect::<Vec<_>>()
        );
    }

    #[test]
    fn lexes_integers_reals_and_exponents() {
        assert_eq!(
            kinds("42 0 2.5 1e-3 1.5E+2 7e2"),
            vec![
                Int(42),
                Int(0),
                Real(2.5),
                Real(1e-3),
                Real(150.0),
                Real(700.0),
                Eof
            ]
        );
    }

    #[test]
    fn range_dots_are_not_a_fraction() {
        assert_eq!(kinds("0..50"), vec![Int(0), DotDot, Int(50), Eof]);
        assert_eq!(kinds("1.x"), vec![Int(1), Dot, Ident("x".into()), Eof]);
    }

    #[test]
    fn lexes_durations_in_seconds() {
        assert_eq!(
            kinds("250ms 2s 1.5s 10us 3min 1h 1e3ms"),
            vec![
                Duration(0.25),
                Duration(2.0),
                Duration(1.5),
                Duration(10.0 * 1e-6),
                Duration(180.0),
                Duration(3600.0),
                Duration(1.0),
                Eof
            ]
        );
    }

    #[test]
    fn lexes_strings_with_escapes() {
        assert_eq!(
            kinds(r#""team/r1" "a\"b" "back\\slash" "two\nlines" """#),
            vec![
                Str("team/r1".into()),
                Str("a\"b".into()),
                Str("back\\slash".into()),
                Str("two\nlines".into()),
                Str(String::new()),
                Eof
            ]
        );
    }

    #[test]
    fn skips_comments_and_whitespace() {
        assert_eq!(
            kinds("a // b c\n\t// d\r\nz // end"),
            vec![Ident("a".into()), Ident("z".into()), Eof]
        );
        assert_eq!(
            kinds("a / b"),
            vec![Ident("a".into()), Slash, Ident("b".into()), Eof]
        );
    }

    #[test]
    fn tracks_lines_and_columns_across_lines() {
        let (tokens, _) = tokenize("class A {\n  x: \"é\";\n}");
        let positions: Vec<(usize, usize, u32, u32)> = tokens
            .iter()
            .map(|t| (t.span.start, t.span.end, t.span.line, t.span.col))
            .collect();
        assert_eq!(
            positions,
            vec![
                (0, 5, 1, 1),
                (6, 7, 1, 7),
                (8, 9, 1, 9),
                (12, 13, 2, 3),
                (13, 14, 2, 4),
                (15, 19, 2, 6),
                (19, 20, 2, 9),
                (21, 22, 3, 1),
                (22, 22, 3, 2)
            ]
        );
    }

    #[test]
    fn unterminated_string_is_reported_at_its_opening_quote() {
        let error = only_error("x = 1;\n  y = \"abc\nz");
        assert_eq!(error.span, Span::new(13, 17, 2, 7));
        assert_eq!(error.message, "unterminated string: add a closing `\"`");
        assert_eq!(error.stage, Stage::Lex);
    }

    #[test]
    fn stray_characters_are_reported_where_they_are() {
        let error = only_error("a\n  b @# c");
        assert_eq!(error.span, Span::new(6, 8, 2, 5));
        assert_eq!(error.message, "unexpected characters `@#`");
        assert_eq!(only_error("a && b").message, "unexpected `&&`; use `and`");
        assert_eq!(only_error("!a").message, "unexpected `!`; use `not`");
        assert_eq!(only_error("é").span, Span::new(0, 2, 1, 1));
    }

    #[test]
    fn stray_characters_become_one_error_token() {
        let (tokens, _) = tokenize("a $ b");
        let kinds: Vec<_> = tokens.into_iter().map(|t| t.kind).collect();
        assert_eq!(
            kinds,
            vec![Ident("a".into()), Error, Ident("b".into()), Eof]
        );
    }

    #[test]
    fn bad_numbers_and_escapes_are_errors_not_panics() {
        let too_big = only_error("99999999999999999999");
        assert!(
            too_big
                .message
                .starts_with("integer literal `99999999999999999999` is too large")
        );
        assert_eq!(
            only_error("1e999").message,
            "real literal `1e999` is out of range"
        );
        assert_eq!(
            only_error("5kg").message,
            "unknown duration unit `kg`; use us, ms, s, min or h"
        );
        assert_eq!(
            only_error("1e308h").message,
            "duration `1e308h` is out of range"
        );
        let escape = only_error(r#""a\qb""#);
        assert_eq!(
            (escape.message.as_str(), escape.span),
            (
                "unknown escape `\\q`; use `\\\"`, `\\\\` or `\\n`",
                Span::new(2, 4, 1, 3)
            )
        );
    }

    #[test]
    fn unit_text_is_raw_up_to_the_closing_bracket() {
        let mut lexer = Lexer::new("[ m/s^2 ] x");
        assert_eq!(lexer.next_token().kind, LBracket);
        assert_eq!(
            lexer.unit_text(),
            Ok(("m/s^2".to_owned(), Span::new(1, 9, 1, 2)))
        );
        assert_eq!(lexer.next_token().kind, Ident("x".into()));
        let mut open = Lexer::new("[m/s\n]");
        open.next_token();
        assert_eq!(open.unit_text(), Err(Span::new(1, 4, 1, 2)));
    }

    #[test]
    fn eof_repeats() {
        let mut lexer = Lexer::new("  ");
        assert_eq!(lexer.next_token().span, Span::new(2, 2, 1, 3));
        assert_eq!(lexer.next_token().kind, Eof);
    }
}
