//! Multiplayer (crate feature `replicon`): a server's accepted edits reach every
//! client. [`NetPlugin`] runs over bevy_replicon and its renet transport
//! (`bevy_replicon_renet`); which side an app plays is the transport it
//! starts ([`transport::host`] or [`transport::connect`]).
//!
//! Only edits travel. A [`NetVolume`] names a volume the same way on every peer
//! (a stable id, and its field's fingerprint, as [`crate::KdSave`] uses):
//! - **Server** (the authority; it may play too: its own [`crate::ApplyEdit`]s
//!   apply at once): each client request is checked (the volume exists, the
//!   brush is one [`crate::ApplyEdit`] takes, finite, within
//!   [`NetSettings::max_brush_reach`], within the client's rate, a request
//!   under [`NetSettings::max_request_bytes`]); an accepted one is applied in
//!   order with the server's own edits, numbered, and sent to every client
//!   that joined the volume. A refused one is answered with the reason,
//!   counted in [`NetStats`], and changes nothing.
//! - **Client**: the volume is marked [`crate::RemoteEdits`]: its
//!   [`crate::ApplyEdit`], [`crate::UndoEdit`] and [`crate::RedoEdit`] go to the
//!   server as requests, and show only when the server's numbered copy comes
//!   back, applied strictly in order, each once ([`kdcontour::edit::Replica`]).
//!   A gap is asked for again. On joining (and rejoining after a drop) it
//!   receives the server's compacted history in the save format, or only the
//!   ops it missed when the server still keeps them; it meshes its own chunks
//!   around its own camera. A volume whose fingerprint differs from the
//!   server's is refused with both fingerprints in the message.
//!
//! Meshing is deterministic, so equal histories give equal meshes on every
//! peer. Undo and redo are requests like edits: they take back the volume's
//! last step, whoever made it. A dedicated server is
//! [`crate::headless::HeadlessPlugins`], the plugin group and [`NetPlugin`].

mod client;
pub mod protocol;
mod server;
pub mod transport;

use bevy::prelude::*;
use bevy_replicon::prelude::*;
use protocol::ServerWire;
use std::collections::BTreeMap;

pub use client::Follower;
pub use server::Authority;

/// The multiplayer subsystem: requests, checks, numbering and replies on the
/// server; requests, ordered application and rejoining on a client. Add it
/// after the plugin group; it adds replicon's plugins and the renet
/// transport's when the app has not.
#[derive(Default)]
pub struct NetPlugin {
    /// Initial limits (copied into the [`NetSettings`] resource).
    pub settings: NetSettings,
}

impl Plugin for NetPlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<RepliconSharedPlugin>() {
            app.add_plugins((RepliconPlugins, bevy_replicon_renet::RepliconRenetPlugins));
        }
        app.insert_resource(self.settings.clone())
            .init_resource::<NetStats>()
            .init_resource::<LocalCursor>()
            .init_resource::<PeerCursors>()
            .register_type::<NetVolume>()
            .register_type::<NetSettings>()
            .add_message::<NetRefused>()
            .add_message::<RequestRefused>()
            .add_message::<NetJoined>()
            .add_client_message_with(Channel::Ordered, protocol::write_raw, protocol::read_client)
            .add_server_message_with(Channel::Ordered, protocol::write_raw, protocol::read_server)
            .make_message_independent::<ServerWire>();
        server::build(app);
        client::build(app);
    }
}

/// Shared volumes that mesh and lack the side's component `C` (they just
/// started).
type NewShared<C> = (With<NetVolume>, With<crate::state::VolumeState>, Without<C>);

/// On a [`crate::KdVolume`]: it is shared over the network, under `id`.
/// Server and clients give the same volume the same id and fingerprint.
#[derive(Component, Clone, Debug, Reflect)]
#[reflect(Component)]
pub struct NetVolume {
    /// The volume's id, the same on every peer.
    pub id: u64,
    /// What its edits are made on (the base field's parameters, seed
    /// included; see [`crate::KdSave::fingerprint_of`]): a client whose
    /// fingerprint differs from the server's is refused.
    pub fingerprint: String,
}

impl NetVolume {
    /// Volume `id` on a field described by `fingerprint`.
    pub fn new(id: u64, fingerprint: impl Into<String>) -> Self {
        NetVolume {
            id,
            fingerprint: fingerprint.into(),
        }
    }
}

/// What the server accepts from a client (a resource; change it at run time).
#[derive(Resource, Clone, Debug, Reflect)]
#[reflect(Resource)]
pub struct NetSettings {
    /// The largest region one brush may change: its bounding sphere's radius
    /// plus its blend radius, in the volume's units.
    pub max_brush_reach: f32,
    /// Edits (undos and redos included) a client may ask for per second, on
    /// average.
    pub edits_per_second: f32,
    /// How many edits a client may ask for at once, above the average.
    pub edit_burst: f32,
    /// The largest request, in bytes (a brush's shape is a CSG tree: this
    /// bounds its size).
    pub max_request_bytes: usize,
    /// Ops the server keeps to send again one by one; a client that misses
    /// older ones gets the whole history.
    pub keep_ops: usize,
}

impl Default for NetSettings {
    fn default() -> Self {
        NetSettings {
            max_brush_reach: 32.0,
            edits_per_second: 30.0,
            edit_burst: 60.0,
            max_request_bytes: 4096,
            keep_ops: 4096,
        }
    }
}

/// Counts of this app's network traffic (server or client side).
#[derive(Resource, Clone, Debug, Default)]
pub struct NetStats {
    /// Requests received (server) or sent (client).
    pub requests: u64,
    /// Edit requests the server accepted.
    pub accepted: u64,
    /// Refused requests, by kind (see [`RequestRefused::kind`]).
    pub refused: BTreeMap<&'static str, u64>,
    /// Ops applied from the server (client).
    pub ops_applied: u64,
    /// Ops received that were already applied or waiting (client).
    pub ops_ignored: u64,
    /// Histories sent (server) or received (client) whole.
    pub snapshots: u64,
    /// Bytes of the histories sent or received whole.
    pub snapshot_bytes: u64,
    /// Payload bytes sent (requests or replies, without the transport's
    /// headers).
    pub bytes_out: u64,
    /// Payload bytes received.
    pub bytes_in: u64,
}

impl NetStats {
    /// All refused requests.
    pub fn refused_total(&self) -> u64 {
        self.refused.values().sum()
    }
}

/// Where this player's brush aims (set by the app each frame; `None`: it
/// aims nowhere): sent to the other players a few times a second.
#[derive(Resource, Clone, Debug, Default, PartialEq)]
pub struct LocalCursor(pub Option<Cursor>);

/// Where the other players' brushes aim, as last heard (a few times a
/// second).
#[derive(Resource, Clone, Debug, Default)]
pub struct PeerCursors(pub Vec<(u64, Cursor)>);

/// A brush's aim on a shared volume.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cursor {
    /// The volume entity.
    pub volume: Entity,
    /// The brush's centre, in the volume's space.
    pub at: Vec3,
    /// The brush's radius.
    pub radius: f32,
}

/// How often brush cursors are sent, in seconds.
const CURSOR_PERIOD: f64 = 0.1;

/// Client side: the server refused a request (or the client's copy of a
/// volume), and why.
#[derive(Message, Clone, Debug)]
pub struct NetRefused {
    /// The volume entity, when the reply named one this client has.
    pub volume: Option<Entity>,
    /// The server's reason.
    pub reason: String,
}

/// Server side: a client's request was refused; it changed nothing.
#[derive(Message, Clone, Debug)]
pub struct RequestRefused {
    /// The client's entity (replicon's `ConnectedClient`).
    pub client: Entity,
    /// What kind of refusal: `malformed`, `too_large`, `rate`,
    /// `unknown_volume`, `other_field`, `bad_brush`, `not_joined`, `repeated`.
    pub kind: &'static str,
    /// The reason sent to the client.
    pub reason: String,
}

/// Client side: a volume took the server's history (on joining or
/// rejoining) and is meshing from it.
#[derive(Message, Clone, Debug)]
pub struct NetJoined {
    /// The volume entity.
    pub volume: Entity,
    /// The last op the history holds.
    pub through: u64,
    /// Bytes of the history received (0: only missed ops followed).
    pub bytes: usize,
}
