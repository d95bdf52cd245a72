use std::net::{SocketAddr, TcpListener, TcpStream};
use std::time::Duration;

use slate_dashboard::ServeError;

use crate::support::{counting_source, http_get, serve_local, within};

#[test]
fn stop_frees_the_port_even_with_clients_connected() {
    let dashboard = serve_local(counting_source());
    let addr = dashboard.local_addr();
    let idle = TcpStream::connect(addr).expect("idle client");
    let (_ws, _) = tungstenite::connect(format!("ws://{addr}/ws")).expect("ws client");
    within(Duration::from_secs(15), move || dashboard.stop());
    TcpListener::bind(addr).expect("port is free after stop");
    drop(idle);
}

#[test]
fn dropping_the_dashboard_stops_it() {
    let dashboard = serve_local(counting_source());
    let addr = dashboard.local_addr();
    assert_eq!(http_get(addr, "/healthz").status, 200);
    within(Duration::from_secs(15), move || drop(dashboard));
    assert!(
        TcpStream::connect(addr).is_err(),
        "still accepting after drop"
    );
    TcpListener::bind(addr).expect("port is free after drop");
}

#[test]
fn serving_on_an_address_in_use_is_a_clear_error() {
    let taken = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = taken.local_addr().unwrap();
    let error = slate_dashboard::serve(addr, counting_source()).expect_err("address is taken");
    assert!(matches!(error, ServeError::AddrInUse { addr: a, .. } if a == addr));
    let message = error.to_string();
    assert!(message.contains("already in use") && message.contains(&addr.to_string()));
}

#[test]
fn serving_on_port_zero_picks_distinct_free_ports() {
    let a = serve_local(counting_source());
    let b = serve_local(counting_source());
    assert_ne!(a.local_addr().port(), 0);
    assert_ne!(a.local_addr(), b.local_addr());
    assert_eq!(a.url(), format!("http://{}/", a.local_addr()));
}

#[test]
fn serving_on_a_foreign_address_is_a_bind_error() {
    // TEST-NET-1 (RFC 5737) is never assigned to this machine, so binding it fails at once.
    let addr = SocketAddr::from(([192, 0, 2, 1], 0));
    let error = slate_dashboard::serve(addr, counting_source()).expect_err("not a local address");
    assert!(matches!(error, ServeError::Bind { .. }), "{error:?}");
}
