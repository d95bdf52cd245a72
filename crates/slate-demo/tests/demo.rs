//! Integration tests of the demo, one module per area (in `demo/`).

mod demo {
    pub mod browser;
    pub mod files;
    pub mod mission;
    pub mod scale;
    pub mod support;
}
