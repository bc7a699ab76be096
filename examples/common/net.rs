//! Playing together (the terrain demo's `--serve ADDR` / `--connect ADDR`):
//! the multiplayer subsystem on the renet transport, and the other players'
//! brushes drawn where they aim.

use bevy::prelude::*;
use bevy_kdcontour::net::{transport, NetPlugin, PeerCursors};
use std::net::SocketAddr;

/// Multiplayer flags.
#[derive(clap::Args, Debug, Clone, Default, Resource)]
pub struct NetArgs {
    /// Host a game on this address and play in it (e.g. 0.0.0.0:5000; others
    /// join with --connect).
    #[arg(long, value_name = "ADDR")]
    pub serve: Option<SocketAddr>,
    /// Join the game hosted at this address (e.g. 127.0.0.1:5000).
    #[arg(long, value_name = "ADDR", conflicts_with = "serve")]
    pub connect: Option<SocketAddr>,
}

impl NetArgs {
    /// Whether this run plays with others.
    pub fn on(&self) -> bool {
        self.serve.is_some() || self.connect.is_some()
    }

    /// Whether this run joins another's game.
    pub fn joins(&self) -> bool {
        self.connect.is_some()
    }
}

/// Adds the multiplayer subsystem and starts hosting or joining (when asked).
pub fn add(app: &mut App, args: &NetArgs) {
    if !args.on() {
        return;
    }
    app.add_plugins(NetPlugin::default())
        .insert_resource(args.clone())
        .add_systems(Startup, start)
        .add_systems(Update, draw_peer_cursors);
}

/// Opens the socket: the transport needs every plugin's channels, so it
/// starts once the app runs.
fn start(world: &mut World) {
    let args = world.resource::<NetArgs>().clone();
    if let Some(addr) = args.serve {
        match transport::host(world, addr, 8) {
            Ok(at) => info!("hosting on {at}: others join with --connect {at}"),
            Err(e) => super::fail(format!("cannot host on {addr}: {e}")),
        }
    }
    if let Some(addr) = args.connect {
        // Any id unique among the host's players will do.
        let id = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(1, |d| d.as_nanos() as u64);
        match transport::connect(world, addr, id) {
            Ok(()) => info!("joining the game at {addr}"),
            Err(e) => super::fail(format!("cannot join {addr}: {e}")),
        }
    }
}

/// The other players' brushes, where they aim (the volume sits at the origin,
/// unrotated).
fn draw_peer_cursors(peers: Res<PeerCursors>, mut gizmos: Gizmos) {
    for (_, c) in &peers.0 {
        gizmos.sphere(
            Isometry3d::from_translation(c.at),
            c.radius,
            Color::srgb(0.2, 0.9, 1.0),
        );
    }
}
