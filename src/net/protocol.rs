//! What travels: a client's [`Request`]s and the server's [`Reply`]s, each CBOR
//! inside one raw message ([`ClientWire`], [`ServerWire`]), so that bytes that
//! do not decode reach this subsystem (to be refused, counted and answered)
//! instead of being dropped by the transport.

use bevy::prelude::*;
use bevy_replicon::bytes::Bytes;
use kdcontour::edit::EditOp;
use serde::{de::DeserializeOwned, Deserialize, Serialize};

/// A client's request, about the volume with net id `volume`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Request {
    /// Take part in a volume: the client's field fingerprint, and (when it
    /// rejoins) the server session and the last op it holds from it.
    Join {
        /// The volume's [`super::NetVolume::id`].
        volume: u64,
        /// The client's [`super::NetVolume::fingerprint`].
        fingerprint: String,
        /// `(session, last op)` the client already holds, when it rejoins.
        have: Option<(u64, u64)>,
    },
    /// Apply an edit, an undo or a redo.
    Edit {
        /// The volume's net id.
        volume: u64,
        /// The op.
        op: EditOp,
    },
    /// Where the player's brush aims (`None`: nowhere), for the others to see.
    Cursor {
        /// The volume's net id.
        volume: u64,
        /// The brush's centre and radius, in the volume's space.
        at: Option<(Vec3, f32)>,
    },
    /// Send again the ops numbered `from..to` (a gap in what arrived).
    Resend {
        /// The volume's net id.
        volume: u64,
        /// The first op wanted.
        from: u64,
        /// One past the last op wanted.
        to: u64,
    },
}

impl Request {
    /// The volume it is about.
    pub fn volume(&self) -> u64 {
        match self {
            Request::Join { volume, .. }
            | Request::Edit { volume, .. }
            | Request::Cursor { volume, .. }
            | Request::Resend { volume, .. } => *volume,
        }
    }
}

/// The server's answer to a client.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Reply {
    /// The client takes part in `volume`: its history as of op `through`, a
    /// save file's bytes (the persist format:
    /// [`crate::persist::file::encode`]), when the client must start from it.
    Joined {
        /// The volume's net id.
        volume: u64,
        /// The server's session (changes each time it starts).
        session: u64,
        /// The last op the history holds.
        through: u64,
        /// The compacted history (`None`: the client's own is current up to
        /// `through`, and the ops after it follow).
        save: Option<Vec<u8>>,
    },
    /// Accepted ops, numbered, in order.
    Ops {
        /// The volume's net id.
        volume: u64,
        /// `(number, op)`, ascending.
        ops: Vec<(u64, EditOp)>,
    },
    /// Where the other players' brushes aim.
    Cursors {
        /// The volume's net id.
        volume: u64,
        /// `(player, centre, radius)`, in the volume's space.
        cursors: Vec<(u64, Vec3, f32)>,
    },
    /// A request was refused and changed nothing.
    Refused {
        /// The volume's net id the request named (0 when it did not decode).
        volume: u64,
        /// Why, in words a player or a developer can act on.
        reason: String,
    },
}

/// A client's raw message: one CBOR [`Request`].
#[derive(Message, Clone, Debug)]
pub struct ClientWire(pub Vec<u8>);

/// The server's raw message to a client: one CBOR [`Reply`].
#[derive(Message, Clone, Debug)]
pub struct ServerWire(pub Vec<u8>);

/// `value` as CBOR.
pub fn encode<T: Serialize>(value: &T) -> Vec<u8> {
    let mut out = Vec::new();
    ciborium::into_writer(value, &mut out).expect("writing CBOR into memory cannot fail");
    out
}

/// CBOR bytes as a `T`, or why not.
pub fn decode<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, String> {
    ciborium::from_reader(bytes).map_err(|e| e.to_string())
}

/// Writes a raw message as it is.
pub(super) fn write_raw<C, M: AsRef<[u8]>>(
    _: &mut C,
    message: &M,
    out: &mut Vec<u8>,
) -> bevy::prelude::Result<()> {
    out.extend_from_slice(message.as_ref());
    Ok(())
}

/// Takes a raw message whole (it never fails: decoding is the receiver's).
pub(super) fn read_client<C>(_: &mut C, bytes: &mut Bytes) -> bevy::prelude::Result<ClientWire> {
    Ok(ClientWire(bytes.split_off(0).to_vec()))
}

/// Takes a raw message whole.
pub(super) fn read_server<C>(_: &mut C, bytes: &mut Bytes) -> bevy::prelude::Result<ServerWire> {
    Ok(ServerWire(bytes.split_off(0).to_vec()))
}

impl AsRef<[u8]> for ClientWire {
    fn as_ref(&self) -> &[u8] {
        &self.0
    }
}

impl AsRef<[u8]> for ServerWire {
    fn as_ref(&self) -> &[u8] {
        &self.0
    }
}
