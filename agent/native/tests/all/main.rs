//! The crate's integration tests, one test binary: each file a module (the vectors shared with Python, the
//! core's message sequences). One binary because each links the library with all of zenoh under the release
//! profile's thin LTO: five binaries took five links, ~8 s each on this 2-core machine, of a fresh clone's
//! `make test`.

mod agent_core;
mod common;
mod imitation_vectors;
mod radio_vectors;
mod records;
mod sph_vectors;
mod vectors;
