//! The Foxglove WebSocket's front door: a thin TCP layer in front of the SDK's server so that
//! clients offering only the protocol's old name connect too.
//!
//! Why: the pinned SDK (foxglove 0.30.3) negotiates only `foxglove.sdk.v1` (and `.v1.1`) and
//! answers any other offer with HTTP 400, while Lichtblick releases before its December 2025
//! change, and other clients written against the ws-protocol, offer only
//! `foxglove.websocket.v1`. Both names stand for the same protocol today (Foxglove's own
//! statement; Lichtblick's change only adds the new name), and no SDK release accepts the old
//! name. So the front door reads the upgrade request, renames an
//! offer of the old name alone to the new one, hands the request to the SDK's server (bound on
//! another loopback port), renames the answer back to the name the client asked for, and from
//! then on relays bytes both ways untouched. `Sec-WebSocket-Accept` depends only on the client's
//! key, so the renamed handshake stays valid. Requests that already offer an SDK name pass
//! through unchanged.

use std::net::SocketAddr;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::task::JoinHandle;
use tracing::debug;

/// The protocol's old name (ws-protocol clients: Lichtblick, roslibjs-foxglove).
pub const OLD_NAME: &str = "foxglove.websocket.v1";
/// The name the SDK negotiates for the same protocol.
const SDK_NAME: &str = "foxglove.sdk.v1";
/// The prefix of every name the SDK accepts.
const SDK_PREFIX: &str = "foxglove.sdk.";
/// The header that carries the offers and the answer.
const HEADER: &str = "sec-websocket-protocol";
/// The longest request or response head read [bytes].
pub const MAX_HEAD: usize = 16 * 1024;

/// The front door: its port; its accept loop ends when it is dropped.
pub struct Front {
    port: u16,
    task: JoinHandle<()>,
}

impl Drop for Front {
    fn drop(&mut self) {
        self.task.abort();
    }
}

impl Front {
    /// Listens on 127.0.0.1:`port` (0: any free port) and relays to the SDK's server at `sdk`.
    pub async fn start(port: u16, sdk: SocketAddr) -> std::io::Result<Front> {
        let listener = TcpListener::bind(("127.0.0.1", port)).await?;
        let port = listener.local_addr()?.port();
        let task = tokio::spawn(async move {
            loop {
                let Ok((client, _)) = listener.accept().await else { continue };
                tokio::spawn(async move {
                    if let Err(e) = relay(client, sdk).await {
                        debug!("foxglove front door: {e}");
                    }
                });
            }
        });
        Ok(Front { port, task })
    }

    /// The port clients connect to.
    pub fn port(&self) -> u16 {
        self.port
    }
}

/// One connection: the renamed handshake, then bytes both ways.
async fn relay(mut client: TcpStream, sdk: SocketAddr) -> std::io::Result<()> {
    let (request, early) = read_head(&mut client).await?;
    let (request, renamed) = rename_offer(&request);
    let mut server = TcpStream::connect(sdk).await?;
    server.write_all(&request).await?;
    server.write_all(&early).await?;
    let (response, early) = read_head(&mut server).await?;
    let response = if renamed { rename_answer(&response) } else { response };
    client.write_all(&response).await?;
    client.write_all(&early).await?;
    tokio::io::copy_bidirectional(&mut client, &mut server).await?;
    Ok(())
}

/// Reads an HTTP head (up to and including the blank line, at most [`MAX_HEAD`] bytes) and
/// returns it with whatever was read past it.
pub async fn read_head<S: AsyncRead + Unpin>(s: &mut S) -> std::io::Result<(Vec<u8>, Vec<u8>)> {
    let mut head = Vec::new();
    let mut buf = [0u8; 2048];
    loop {
        if let Some(end) = head.windows(4).position(|w| w == b"\r\n\r\n") {
            let rest = head.split_off(end + 4);
            return Ok((head, rest));
        }
        if head.len() >= MAX_HEAD {
            return Ok((head, Vec::new()));
        }
        let n = s.read(&mut buf).await?;
        if n == 0 {
            return Ok((head, Vec::new()));
        }
        head.extend_from_slice(&buf[..n]);
    }
}

/// The offered names of every subprotocol header line of `head`.
fn offers(head: &str) -> Vec<&str> {
    head.split("\r\n").filter_map(header_value).flat_map(|v| v.split(',')).map(str::trim).collect()
}

/// The value of a `Sec-WebSocket-Protocol` line (the name matched in any case).
fn header_value(line: &str) -> Option<&str> {
    let (name, value) = line.split_once(':')?;
    name.trim().eq_ignore_ascii_case(HEADER).then_some(value)
}

/// `head` with the old name offered in place of the SDK's, if the client offers the old name
/// and no name of the SDK's; and whether it renamed.
fn rename_offer(head: &[u8]) -> (Vec<u8>, bool) {
    let Ok(text) = std::str::from_utf8(head) else { return (head.to_vec(), false) };
    let names = offers(text);
    if !names.contains(&OLD_NAME) || names.iter().any(|n| n.starts_with(SDK_PREFIX)) {
        return (head.to_vec(), false);
    }
    (rename_lines(text, OLD_NAME, SDK_NAME).into_bytes(), true)
}

/// `head` (the SDK's answer) with its chosen name renamed back to the old one.
fn rename_answer(head: &[u8]) -> Vec<u8> {
    match std::str::from_utf8(head) {
        Ok(text) => rename_lines(text, SDK_NAME, OLD_NAME).into_bytes(),
        Err(_) => head.to_vec(),
    }
}

/// Every subprotocol header line of `text` with the name `from` (a whole, comma-separated
/// entry) replaced by `to`; other lines untouched.
fn rename_lines(text: &str, from: &str, to: &str) -> String {
    text.split("\r\n")
        .map(|line| match (header_value(line), line.split_once(':')) {
            (Some(value), Some((name, _))) => {
                let names: Vec<&str> = value.split(',').map(|n| if n.trim() == from { to } else { n.trim() }).collect();
                format!("{name}: {}", names.join(", "))
            }
            _ => line.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\r\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    const OLD_ONLY: &str =
        "GET / HTTP/1.1\r\nHost: x\r\nSec-WebSocket-Protocol: foxglove.websocket.v1\r\nSec-WebSocket-Key: k\r\n\r\n";

    #[test]
    fn an_offer_of_the_old_name_alone_is_renamed_and_the_answer_back() {
        let (req, renamed) = rename_offer(OLD_ONLY.as_bytes());
        assert!(renamed);
        let req = String::from_utf8(req).expect("utf8");
        assert!(req.contains("Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n"), "{req}");
        assert!(
            req.starts_with("GET / HTTP/1.1\r\nHost: x\r\n") && req.ends_with("Sec-WebSocket-Key: k\r\n\r\n"),
            "{req}"
        );
        let answer = "HTTP/1.1 101 Switching Protocols\r\nsec-websocket-protocol: foxglove.sdk.v1\r\nsec-websocket-accept: a\r\n\r\n";
        let back = String::from_utf8(rename_answer(answer.as_bytes())).expect("utf8");
        assert_eq!(back, answer.replace("foxglove.sdk.v1", "foxglove.websocket.v1"));
    }

    #[test]
    fn offers_with_an_sdk_name_pass_untouched() {
        for h in [
            "GET / HTTP/1.1\r\nsec-websocket-protocol: foxglove.websocket.v1, foxglove.sdk.v1\r\n\r\n",
            "GET / HTTP/1.1\r\nSec-WebSocket-Protocol: foxglove.sdk.v1.1\r\nSec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n",
            "GET / HTTP/1.1\r\nSec-WebSocket-Protocol: other\r\n\r\n",
            "GET / HTTP/1.1\r\n\r\n",
        ] {
            assert_eq!(rename_offer(h.as_bytes()), (h.as_bytes().to_vec(), false), "{h}");
        }
    }

    #[test]
    fn a_longer_offer_keeps_its_other_names() {
        let h = "GET / HTTP/1.1\r\nSEC-WEBSOCKET-PROTOCOL: x.v2 ,foxglove.websocket.v1\r\n\r\n";
        let (req, renamed) = rename_offer(h.as_bytes());
        assert!(renamed);
        assert_eq!(
            String::from_utf8(req).expect("utf8"),
            "GET / HTTP/1.1\r\nSEC-WEBSOCKET-PROTOCOL: x.v2, foxglove.sdk.v1\r\n\r\n"
        );
    }

    #[tokio::test]
    async fn a_head_is_split_from_what_follows_it() {
        let mut input: &[u8] = b"GET / HTTP/1.1\r\nA: b\r\n\r\n\x81\x01x";
        let (head, rest) = read_head(&mut input).await.expect("read");
        assert_eq!(head, b"GET / HTTP/1.1\r\nA: b\r\n\r\n");
        assert_eq!(rest, b"\x81\x01x");
    }
}
