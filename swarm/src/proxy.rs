//! A TCP proxy between one agent's Zenoh session and the hub's router, for link-level faults
//! that Zenoh itself sees (issue 4; `[[failures]]` kinds `link_stall`, `link_close`,
//! `link_restore`).
//!
//! Why: the per-message netem layer drops and delays shares, but the Zenoh session underneath
//! stays healthy. A radio that fades out is different: nothing crosses the link at all, the
//! session's lease expires on both sides, liveliness tokens vanish, and when the radio returns
//! the client has to reconnect and re-declare its subscriptions and its token. Kernel netem is not
//! available here, so the launcher puts this proxy in the agent's path and drives it:
//!
//! - [`LinkState::Up`]: bytes are pumped both ways as they come.
//! - [`LinkState::Stalled`]: nothing is read or written any more, in either direction, on the
//!   connections that exist, and new connections are accepted but not forwarded. Nothing is
//!   closed: the data sits in socket buffers, and the peers find out only when their leases
//!   expire, as with a radio out of range (Toxiproxy's `timeout` toxic with timeout 0).
//! - [`LinkState::Closed`]: every connection is shut down (a graceful close that both sides see
//!   at once) and new ones are closed as soon as they are accepted (Toxiproxy's disabled proxy).
//! - Back to `Up` (restore): connections held while stalled are forwarded from now on, stalled
//!   pumps resume (a session Zenoh has already given up on then sees its peer's close), and the
//!   client's own reconnection goes through.
//!
//! Scouting and gossip are off in every session (see `swarm_wire::session`), so the agent has
//! no way around the proxy.

use std::net::SocketAddr;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::watch;
use tracing::{debug, info, warn};

/// What the proxy does with the link.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkState {
    /// Forward everything.
    Up,
    /// Forward nothing, close nothing.
    Stalled,
    /// Close everything, accept nothing.
    Closed,
}

/// A running proxy; dropping it stops accepting (existing pumps end with their sockets).
#[derive(Debug)]
pub struct LinkProxy {
    addr: SocketAddr,
    state: watch::Sender<LinkState>,
    task: tokio::task::JoinHandle<()>,
}

impl Drop for LinkProxy {
    fn drop(&mut self) {
        self.task.abort();
    }
}

impl LinkProxy {
    /// Listens on a free port of 127.0.0.1 and forwards every connection to `upstream`.
    pub async fn start(upstream: SocketAddr) -> std::io::Result<LinkProxy> {
        let listener = TcpListener::bind("127.0.0.1:0").await?;
        let addr = listener.local_addr()?;
        let (state, rx) = watch::channel(LinkState::Up);
        let task = tokio::spawn(accept_loop(listener, upstream, rx));
        Ok(LinkProxy { addr, state, task })
    }

    /// The address agents connect to.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The Zenoh locator of [`LinkProxy::addr`].
    pub fn locator(&self) -> String {
        format!("tcp/{}", self.addr)
    }

    /// Changes what the link does, at once.
    pub fn set(&self, s: LinkState) {
        info!(proxy = %self.addr, state = ?s, "link state");
        self.state.send_replace(s);
    }

    /// What the link does now.
    #[cfg(test)]
    pub fn state(&self) -> LinkState {
        *self.state.borrow()
    }
}

async fn accept_loop(listener: TcpListener, upstream: SocketAddr, state: watch::Receiver<LinkState>) {
    loop {
        let (client, peer) = match listener.accept().await {
            Ok(c) => c,
            Err(e) => {
                warn!("proxy accept: {e}");
                continue;
            }
        };
        debug!(%peer, "proxy: connection");
        tokio::spawn(serve(client, upstream, state.clone()));
    }
}

/// Waits until the link is not stalled; returns the state it settled in.
async fn settled(state: &mut watch::Receiver<LinkState>) -> LinkState {
    match state.wait_for(|s| *s != LinkState::Stalled).await {
        Ok(s) => *s,
        Err(_) => LinkState::Closed,
    }
}

async fn serve(client: TcpStream, upstream: SocketAddr, mut state: watch::Receiver<LinkState>) {
    if settled(&mut state).await == LinkState::Closed {
        return; // dropped: closed at once
    }
    let server = match TcpStream::connect(upstream).await {
        Ok(s) => s,
        Err(e) => {
            warn!("proxy: cannot reach {upstream}: {e}");
            return;
        }
    };
    let _ = client.set_nodelay(true);
    let _ = server.set_nodelay(true);
    let (cr, cw) = client.into_split();
    let (sr, sw) = server.into_split();
    let up = tokio::spawn(pump(cr, sw, state.clone()));
    let down = tokio::spawn(pump(sr, cw, state));
    let _ = tokio::join!(up, down);
}

/// Copies `from` to `to` while the link is up; holds while stalled; ends (closing `to`) on EOF,
/// an error, or a close of the link.
async fn pump(
    mut from: tokio::net::tcp::OwnedReadHalf,
    mut to: tokio::net::tcp::OwnedWriteHalf,
    mut state: watch::Receiver<LinkState>,
) {
    let mut buf = vec![0u8; 64 * 1024];
    loop {
        if settled(&mut state).await == LinkState::Closed {
            break;
        }
        let n = tokio::select! {
            r = from.read(&mut buf) => match r {
                Ok(0) | Err(_) => break,
                Ok(n) => n,
            },
            // The state changed while waiting for bytes: look at it again before reading more.
            _ = state.changed() => continue,
        };
        // Bytes read just as the link stalls are held until it settles, not written.
        if settled(&mut state).await == LinkState::Closed {
            break;
        }
        if to.write_all(&buf[..n]).await.is_err() {
            break;
        }
    }
    let _ = to.shutdown().await;
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    /// An echo server; returns its address.
    async fn echo() -> SocketAddr {
        let l = TcpListener::bind("127.0.0.1:0").await.expect("bind");
        let addr = l.local_addr().expect("addr");
        tokio::spawn(async move {
            while let Ok((mut s, _)) = l.accept().await {
                tokio::spawn(async move {
                    let mut b = [0u8; 1024];
                    while let Ok(n) = s.read(&mut b).await {
                        if n == 0 || s.write_all(&b[..n]).await.is_err() {
                            break;
                        }
                    }
                });
            }
        });
        addr
    }

    async fn roundtrip(s: &mut TcpStream, msg: &[u8], wait: Duration) -> Option<Vec<u8>> {
        s.write_all(msg).await.ok()?;
        let mut b = vec![0u8; msg.len()];
        match tokio::time::timeout(wait, s.read_exact(&mut b)).await {
            Ok(Ok(_)) => Some(b),
            _ => None,
        }
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn forwards_stalls_silently_then_resumes() {
        let p = LinkProxy::start(echo().await).await.expect("proxy");
        let mut s = TcpStream::connect(p.addr()).await.expect("connect");
        assert_eq!(roundtrip(&mut s, b"one", Duration::from_secs(5)).await.as_deref(), Some(&b"one"[..]));
        p.set(LinkState::Stalled);
        assert_eq!(roundtrip(&mut s, b"two", Duration::from_millis(300)).await, None, "nothing crosses a stalled link");
        // The connection is not closed: a read sees neither data nor EOF.
        let mut b = [0u8; 1];
        assert!(tokio::time::timeout(Duration::from_millis(200), s.read(&mut b)).await.is_err());
        p.set(LinkState::Up);
        let mut b = [0u8; 3];
        tokio::time::timeout(Duration::from_secs(5), s.read_exact(&mut b)).await.expect("resumes").expect("read");
        assert_eq!(&b, b"two", "what was sent while stalled arrives after the restore");
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn close_ends_connections_and_refuses_new_ones_until_restored() {
        let p = LinkProxy::start(echo().await).await.expect("proxy");
        let mut s = TcpStream::connect(p.addr()).await.expect("connect");
        assert!(roundtrip(&mut s, b"x", Duration::from_secs(5)).await.is_some());
        p.set(LinkState::Closed);
        let mut b = [0u8; 8];
        let n = tokio::time::timeout(Duration::from_secs(5), s.read(&mut b)).await.expect("closed promptly");
        assert!(matches!(n, Ok(0) | Err(_)), "EOF or reset: {n:?}");
        let mut again = TcpStream::connect(p.addr()).await.expect("the listener accepts");
        let n = tokio::time::timeout(Duration::from_secs(5), again.read(&mut b)).await.expect("closed promptly");
        assert!(matches!(n, Ok(0) | Err(_)), "a new connection is closed at once: {n:?}");
        p.set(LinkState::Up);
        assert_eq!(p.state(), LinkState::Up);
        let mut fresh = TcpStream::connect(p.addr()).await.expect("connect");
        assert_eq!(roundtrip(&mut fresh, b"back", Duration::from_secs(5)).await.as_deref(), Some(&b"back"[..]));
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_connection_made_while_stalled_is_forwarded_after_the_restore() {
        let p = LinkProxy::start(echo().await).await.expect("proxy");
        p.set(LinkState::Stalled);
        let mut s = TcpStream::connect(p.addr()).await.expect("accepted, held");
        assert_eq!(roundtrip(&mut s, b"hi", Duration::from_millis(300)).await, None);
        p.set(LinkState::Up);
        let mut b = [0u8; 2];
        tokio::time::timeout(Duration::from_secs(5), s.read_exact(&mut b)).await.expect("forwarded").expect("read");
        assert_eq!(&b, b"hi");
    }
}
