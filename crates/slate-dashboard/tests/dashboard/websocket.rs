use std::net::{SocketAddr, TcpStream};
use std::time::Duration;

use serde_json::Value;
use tungstenite::{Message, WebSocket};

use crate::support::{IO_TIMEOUT, counting_source, serve_local, within};

fn connect(addr: SocketAddr) -> WebSocket<TcpStream> {
    let stream = TcpStream::connect_timeout(&addr, IO_TIMEOUT).expect("connect");
    stream.set_read_timeout(Some(IO_TIMEOUT)).unwrap();
    let (socket, _) = tungstenite::client(format!("ws://{addr}/ws"), stream).expect("handshake");
    socket
}

/// The next text message as JSON (pings and the like skipped).
fn next_snapshot(socket: &mut WebSocket<TcpStream>) -> Value {
    loop {
        match socket.read().expect("read") {
            Message::Text(text) => return serde_json::from_str(text.as_str()).expect("JSON"),
            Message::Close(frame) => panic!("closed early: {frame:?}"),
            _ => {}
        }
    }
}

#[test]
fn websocket_pushes_successive_snapshots() {
    let dashboard = serve_local(counting_source());
    let mut socket = connect(dashboard.local_addr());
    let times: Vec<f64> = (0..4)
        .map(|_| next_snapshot(&mut socket)["time"].as_f64().expect("time"))
        .collect();
    assert!(times.windows(2).all(|w| w[1] > w[0]), "times {times:?}");
}

#[test]
fn websocket_clients_share_the_stream_and_each_gets_pushes() {
    let dashboard = serve_local(counting_source());
    let mut a = connect(dashboard.local_addr());
    let mut b = connect(dashboard.local_addr());
    for _ in 0..2 {
        assert!(next_snapshot(&mut a)["time"].is_number());
        assert!(next_snapshot(&mut b)["time"].is_number());
    }
}

#[test]
fn websocket_is_closed_when_the_dashboard_stops() {
    let dashboard = serve_local(counting_source());
    let mut socket = connect(dashboard.local_addr());
    next_snapshot(&mut socket);
    within(Duration::from_secs(15), move || dashboard.stop());
    let ended = within(Duration::from_secs(15), move || {
        loop {
            match socket.read() {
                Ok(Message::Close(_)) | Err(_) => return true,
                Ok(_) => {}
            }
        }
    });
    assert!(ended);
}
