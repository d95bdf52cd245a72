//! The page: one HTML document with its stylesheet and script inlined at first use, so it
//! is a single response with no external resources (works offline, no build step).

use std::sync::LazyLock;

const HTML: &str = include_str!("assets/index.html");
const CSS: &str = include_str!("assets/dashboard.css");
const JS: &str = include_str!("assets/dashboard.js");

/// Where the stylesheet and the script go in `index.html`.
const CSS_SLOT: &str = "/*@DASHBOARD_CSS@*/";
const JS_SLOT: &str = "/*@DASHBOARD_JS@*/";

static PAGE: LazyLock<String> = LazyLock::new(|| HTML.replace(CSS_SLOT, CSS).replace(JS_SLOT, JS));

/// The complete page.
pub(crate) fn html() -> &'static str {
    &PAGE
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn page_inlines_the_stylesheet_and_the_script() {
        let page = html();
        assert!(!page.contains(CSS_SLOT) && !page.contains(JS_SLOT));
        assert!(page.contains("data-testid=\"map\""));
        assert!(page.len() > HTML.len() + CSS.len() / 2);
    }

    #[test]
    fn page_loads_nothing_from_elsewhere() {
        let page = html();
        for needle in ["http://", "https://", "src=\"//", "@import"] {
            assert!(!page.contains(needle), "page references {needle}");
        }
    }
}
