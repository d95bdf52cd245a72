//! Headless Chromium driven over the Chrome DevTools Protocol, for slate's browser tests: no
//! npm, no WebDriver, just the browser binary and a websocket.
//!
//! [`chromium`] finds the binary (or says why the test should skip), [`Chromium::launch`]
//! starts it in its own process group (killed, group and all, when the guard drops), and
//! [`Chromium::page`] opens a [`Page`] to navigate, evaluate, wait, move the mouse, take
//! screenshots and collect console errors. Everything here panics on failure with a message
//! meant for a test log: these are test helpers, and a failing step fails the test.
//!
//! One limit, passed at launch, bounds every wait: the DevTools URL appearing, each read
//! from the protocol socket, and each [`Page::wait_text`].
//!
//! ```
//! use std::time::Duration;
//!
//! let Some(binary) = slate_cdp::chromium() else {
//!     return; // no Chromium here: the test skips
//! };
//! let browser = slate_cdp::Chromium::launch(&binary, Duration::from_secs(20));
//! let mut page = browser.page();
//! page.navigate("data:text/html,<p data-testid=greeting>hello</p>");
//! assert_eq!(page.wait_text("greeting", |t| !t.is_empty()), "hello");
//! assert!(page.console_errors().is_empty(), "{}", browser.log_tail());
//! ```
#![warn(missing_docs)]

mod chromium;
mod page;

pub use chromium::{Chromium, chromium};
pub use page::Page;
