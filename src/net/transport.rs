//! Starting the renet transport (UDP, netcode) as a server or a client: the
//! resources `bevy_replicon_renet` drives, built from the app's replicon
//! channels, so call these after every plugin is added.

use bevy::prelude::*;
use bevy_replicon::prelude::RepliconChannels;
use bevy_replicon_renet::netcode::{
    ClientAuthentication, NetcodeClientTransport, NetcodeServerTransport, ServerAuthentication,
    ServerConfig,
};
use bevy_replicon_renet::renet::ConnectionConfig;
use bevy_replicon_renet::{RenetChannelsExt, RenetClient, RenetServer};
use std::net::{SocketAddr, UdpSocket};
use std::time::SystemTime;

/// This protocol's id: a client of another game (or version) cannot connect.
pub const PROTOCOL_ID: u64 = u64::from_le_bytes(*b"kdcont01");

fn connection(world: &World) -> ConnectionConfig {
    let channels = world.resource::<RepliconChannels>();
    ConnectionConfig {
        server_channels_config: channels.server_configs(),
        client_channels_config: channels.client_configs(),
        ..Default::default()
    }
}

fn now() -> std::time::Duration {
    SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .unwrap_or_default()
}

/// Makes the app a server listening on `addr` (port 0: any free port) for
/// at most `max_clients`; returns the address it listens on. No encryption:
/// for LAN and loopback play.
pub fn host(
    world: &mut World,
    addr: SocketAddr,
    max_clients: usize,
) -> std::io::Result<SocketAddr> {
    let socket = UdpSocket::bind(addr)?;
    let local = socket.local_addr()?;
    let config = ServerConfig {
        current_time: now(),
        max_clients,
        protocol_id: PROTOCOL_ID,
        public_addresses: vec![local],
        authentication: ServerAuthentication::Unsecure,
    };
    let transport = NetcodeServerTransport::new(config, socket)?;
    let server = RenetServer::new(connection(world));
    world.insert_resource(server);
    world.insert_resource(transport);
    Ok(local)
}

/// Makes the app a client of the server at `server`, as `client_id` (unique
/// among the server's clients).
pub fn connect(world: &mut World, server: SocketAddr, client_id: u64) -> std::io::Result<()> {
    let bind: SocketAddr = if server.is_ipv4() {
        ([0, 0, 0, 0], 0).into()
    } else {
        (std::net::Ipv6Addr::UNSPECIFIED, 0).into()
    };
    let bind = if server.ip().is_loopback() {
        SocketAddr::new(server.ip(), 0)
    } else {
        bind
    };
    let socket = UdpSocket::bind(bind)?;
    let authentication = ClientAuthentication::Unsecure {
        client_id,
        protocol_id: PROTOCOL_ID,
        server_addr: server,
        user_data: None,
    };
    let transport = NetcodeClientTransport::new(now(), authentication, socket)
        .map_err(std::io::Error::other)?;
    let client = RenetClient::new(connection(world));
    // A new connection, not an update of an old one (the transport starts
    // connecting when the client resource is added).
    world.remove_resource::<RenetClient>();
    world.remove_resource::<NetcodeClientTransport>();
    world.insert_resource(client);
    world.insert_resource(transport);
    Ok(())
}

/// Ends the client's connection (it can [`connect`] again).
pub fn disconnect(world: &mut World) {
    if let Some(mut client) = world.get_resource_mut::<RenetClient>() {
        client.disconnect();
    }
}
