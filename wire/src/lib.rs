//! The wire of a swarm run: every message that crosses Zenoh, the key expressions they travel
//! on, and how every process of the project opens its Zenoh session.
//!
//! - [`msg`]: one envelope enum, [`Msg`], for every payload. Postcard encoded, variants only ever
//!   appended, so `swarm tap` can decode any key of a run without knowing which it is.
//! - [`keys`]: the key-expression space, `swarm/{run}/...`, built in one place ([`Keys`]).
//! - [`session`]: Zenoh configs for the hub (router) and everyone else (clients), with multicast
//!   scouting off everywhere so parallel runs cannot cross-talk; [`session::Writer`] writes on
//!   every key a process publishes (a publisher that declares nothing: see why there).
//! - [`external`]: the JSON view and command an agent exchanges with an external controller
//!   (the only payloads that are not a [`Msg`]).
//! - [`plumbing`]: what every process repeats around its session, written once: subscribe a key
//!   into a channel, watch liveliness tokens, fetch the scenario text from the hub.
//!
//! Architecture invariant: this crate defines shapes, not behaviour. It has no simulation,
//! perception or control code, and nothing here reads ground truth.

pub mod external;
pub mod keys;
pub mod msg;
pub mod plumbing;
pub mod session;

#[cfg(test)]
mod fuzz;

pub use keys::Keys;
pub use msg::*;

/// Errors of the wire layer.
#[derive(Debug, thiserror::Error)]
pub enum WireError {
    /// A payload could not be decoded as a [`Msg`].
    #[error("malformed message ({len} bytes): {source}")]
    Decode {
        /// Payload size.
        len: usize,
        /// Postcard's reason.
        source: postcard::Error,
    },
    /// A part given to [`Msg::senses_from_encoded`] was not an encoded [`Msg::Sense`].
    #[error("not an encoded sensor frame ({len} bytes)")]
    NotSense {
        /// Its size.
        len: usize,
    },
    /// A payload held a whole [`Msg`] and more bytes after it.
    #[error("malformed message ({len} bytes): {extra} bytes after its end")]
    Trailing {
        /// Payload size.
        len: usize,
        /// Bytes left after the message.
        extra: usize,
    },
    /// A message could not be encoded.
    #[error("cannot encode message: {0}")]
    Encode(postcard::Error),
    /// A bad run id or key component.
    #[error("invalid key component {0:?}: use only [A-Za-z0-9_-]")]
    BadKey(String),
    /// Nothing answered a query before the deadline (no hub serving the run yet).
    #[error("nothing answered {key} within {wait_s} s")]
    NoReply {
        /// The key asked.
        key: String,
        /// How long it was asked [s].
        wait_s: f64,
    },
    /// Zenoh refused something (its error type is a boxed trait object, kept as text).
    #[error("zenoh: {0}")]
    Zenoh(String),
}

impl WireError {
    /// Wraps a zenoh error.
    pub fn zenoh(e: impl std::fmt::Display) -> Self {
        WireError::Zenoh(e.to_string())
    }
}
