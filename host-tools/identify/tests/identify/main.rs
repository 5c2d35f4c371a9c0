//! Integration tests of mil-identify: one test binary (fast to link) with a module per area.

mod common;
mod excitation;
mod h1;
mod record;
mod table;
