//! A TCP proxy on 127.0.0.1 that counts the bytes crossing it each way: put between
//! two Zenoh sessions, it measures what a link really carries (Zenoh's framing, key
//! expressions, keep-alives and slate's messages), not what slate thinks it sent.

use std::io::{ErrorKind, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

/// Bytes seen so far, each way.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    /// From the connecting side to the listening side.
    pub forward: u64,
    /// Back.
    pub backward: u64,
}

impl Counts {
    /// Both ways.
    pub fn total(self) -> u64 {
        self.forward + self.backward
    }

    /// What was counted since `earlier`.
    pub fn since(self, earlier: Counts) -> Counts {
        Counts {
            forward: self.forward - earlier.forward,
            backward: self.backward - earlier.backward,
        }
    }
}

/// The running proxy; dropping it stops its threads.
pub struct Proxy {
    /// The port it listens on.
    pub port: u16,
    forward: Arc<AtomicU64>,
    backward: Arc<AtomicU64>,
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
}

impl Proxy {
    /// Listens on a free port of 127.0.0.1 and forwards every connection to `target`.
    pub fn start(target: SocketAddr) -> std::io::Result<Proxy> {
        let listener = TcpListener::bind("127.0.0.1:0")?;
        listener.set_nonblocking(true)?;
        let port = listener.local_addr()?.port();
        let forward = Arc::new(AtomicU64::new(0));
        let backward = Arc::new(AtomicU64::new(0));
        let stop = Arc::new(AtomicBool::new(false));
        let (f, b, s) = (forward.clone(), backward.clone(), stop.clone());
        let acceptor = std::thread::Builder::new()
            .name("bench-proxy".into())
            .spawn(move || accept_loop(&listener, target, &f, &b, &s))?;
        Ok(Proxy {
            port,
            forward,
            backward,
            stop,
            threads: vec![acceptor],
        })
    }

    /// The bytes counted so far.
    pub fn counts(&self) -> Counts {
        Counts {
            forward: self.forward.load(Ordering::SeqCst),
            backward: self.backward.load(Ordering::SeqCst),
        }
    }
}

impl Drop for Proxy {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

fn accept_loop(
    listener: &TcpListener,
    target: SocketAddr,
    forward: &Arc<AtomicU64>,
    backward: &Arc<AtomicU64>,
    stop: &Arc<AtomicBool>,
) {
    let mut pipes = Vec::new();
    while !stop.load(Ordering::SeqCst) {
        match listener.accept() {
            Ok((client, _)) => {
                let _ = client.set_nonblocking(false);
                if let Ok(server) = TcpStream::connect(target) {
                    pipes.extend(pipe(client, server, forward, backward, stop));
                }
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(5));
            }
            Err(_) => break,
        }
    }
    for p in pipes {
        let _ = p.join();
    }
}

/// Copies both ways between two connected sockets, counting.
fn pipe(
    client: TcpStream,
    server: TcpStream,
    forward: &Arc<AtomicU64>,
    backward: &Arc<AtomicU64>,
    stop: &Arc<AtomicBool>,
) -> Vec<JoinHandle<()>> {
    let mut out = Vec::new();
    for (from, to, count) in [
        (client.try_clone(), server.try_clone(), forward.clone()),
        (server.try_clone(), client.try_clone(), backward.clone()),
    ] {
        let (Ok(from), Ok(to)) = (from, to) else {
            continue;
        };
        let stop = stop.clone();
        let copy = move || copy(from, to, &count, &stop);
        if let Ok(t) = std::thread::Builder::new()
            .name("bench-proxy-pipe".into())
            .spawn(copy)
        {
            out.push(t);
        }
    }
    out
}

fn copy(mut from: TcpStream, mut to: TcpStream, count: &AtomicU64, stop: &AtomicBool) {
    let _ = from.set_read_timeout(Some(Duration::from_millis(50)));
    let _ = from.set_nodelay(true);
    let _ = to.set_nodelay(true);
    let mut buf = vec![0u8; 64 * 1024];
    loop {
        match from.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => {
                count.fetch_add(n as u64, Ordering::SeqCst);
                if to.write_all(&buf[..n]).is_err() {
                    break;
                }
            }
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                if stop.load(Ordering::SeqCst) {
                    break;
                }
            }
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(_) => break,
        }
    }
    let _ = to.shutdown(Shutdown::Write);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_proxy_forwards_and_counts_both_ways() {
        let server = TcpListener::bind("127.0.0.1:0").unwrap();
        let proxy = Proxy::start(server.local_addr().unwrap()).unwrap();
        let mut client = TcpStream::connect(("127.0.0.1", proxy.port)).unwrap();
        let (mut inner, _) = server.accept().unwrap();
        client.write_all(b"hello").unwrap();
        let mut got = [0u8; 5];
        inner.read_exact(&mut got).unwrap();
        inner.write_all(b"ok").unwrap();
        let mut back = [0u8; 2];
        client.read_exact(&mut back).unwrap();
        assert_eq!((&got, &back), (b"hello", b"ok"));
        assert_eq!(
            proxy.counts(),
            Counts {
                forward: 5,
                backward: 2
            }
        );
        drop((client, inner));
        drop(proxy);
    }
}
