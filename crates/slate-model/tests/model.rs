//! Integration tests of the world model, one module per area.

mod model {
    pub mod active;
    pub mod batch;
    pub mod classes;
    pub mod concurrency;
    pub mod hooks;
    pub mod merge;
    pub mod own_writes;
    pub mod reference;
    pub mod values;
    pub mod watch;
    pub mod world;
}
