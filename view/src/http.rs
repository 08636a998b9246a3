//! The page's HTTP side: a small HTTP/1.1 server on tokio, six routes and no framework, so the
//! page needs no build step and the binary no web stack:
//!
//! - `/`: the page (HTML, JS and canvas, embedded in the binary);
//! - `/events`: Server-Sent Events: the world (`event: world`), the recent trails (`event:
//!   trails`, see `trails`; again after each replay seek), then the latest frame whenever it
//!   changes (a slow browser skips frames; it never slows the producer);
//! - `/state`: the world and the latest frame as one JSON object (scripts, tests);
//! - `/trails`: the recent trails, as the `trails` event carries them (scripts);
//! - `/scan?id=N`: UAV N's latest scan in the world (scans on demand, see `scans`; 404 before
//!   the first);
//! - `/control?cmd=...`: replay's play, pause, seek and speed (404 on a live view).

use super::scans::ScanSource;
use super::trails::TrailSource;
use std::sync::Arc;
use swarm_types::UavId;
use tokio::io::AsyncWriteExt;
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{mpsc, watch};
use tracing::debug;

/// The page.
const PAGE: &str = include_str!("page.html");

/// What the page shows now: JSON texts of the world and of the latest frame.
#[derive(Debug, Default, Clone)]
pub struct Snapshot {
    /// The world frame.
    pub world: Option<Arc<str>>,
    /// The latest step frame.
    pub frame: Option<Arc<str>>,
    /// Changed when the trails a page holds no longer lead to the frame (a replay's seek): the
    /// page is sent the trails again before that frame.
    pub trails_epoch: u64,
}

/// A replay command: the query pairs of `/control`.
pub type Command = Vec<(String, String)>;

/// What the page's server answers from: the snapshots, the replay's controls (none on a live
/// view), the scans and the trails.
#[derive(Clone)]
pub struct Sources {
    /// The world and the latest frame.
    pub snap: watch::Receiver<Snapshot>,
    /// Where `/control` commands go.
    pub control: Option<mpsc::UnboundedSender<Command>>,
    /// Where `/scan` answers come from.
    pub scans: Arc<dyn ScanSource>,
    /// Where the trails a page starts with come from.
    pub trails: Arc<dyn TrailSource>,
}

/// Serves the page on `listener` until the process ends.
pub async fn serve(listener: TcpListener, sources: Sources) {
    loop {
        let Ok((stream, _)) = listener.accept().await else { continue };
        let sources = sources.clone();
        tokio::spawn(async move {
            if let Err(e) = handle(stream, sources).await {
                debug!("page connection: {e}");
            }
        });
    }
}

async fn handle(mut s: TcpStream, Sources { snap, control, scans, trails }: Sources) -> std::io::Result<()> {
    let Some(target) = read_target(&mut s).await? else { return Ok(()) };
    let (path, query) = target.split_once('?').unwrap_or((&target, ""));
    match path {
        "/" | "/index.html" => respond(&mut s, "200 OK", "text/html; charset=utf-8", PAGE.as_bytes()).await,
        "/state" => {
            let now = snap.borrow().clone();
            let body = format!(
                "{{\"world\":{},\"frame\":{}}}",
                now.world.as_deref().unwrap_or("null"),
                now.frame.as_deref().unwrap_or("null")
            );
            respond(&mut s, "200 OK", "application/json", body.as_bytes()).await
        }
        "/events" => events(s, snap, trails).await,
        "/trails" => respond(&mut s, "200 OK", "application/json", trails.trails().to_string().as_bytes()).await,
        "/scan" => {
            let id = parse_query(query).into_iter().find(|(k, _)| k == "id").and_then(|(_, v)| v.parse::<UavId>().ok());
            match id.and_then(|id| scans.scan(id)) {
                Some(p) => respond(&mut s, "200 OK", "application/json", p.to_json().as_bytes()).await,
                None => respond(&mut s, "404 Not Found", "text/plain", b"no scan of that UAV yet").await,
            }
        }
        "/control" => match control {
            Some(c) => {
                let _ = c.send(parse_query(query));
                respond(&mut s, "204 No Content", "text/plain", b"").await
            }
            None => respond(&mut s, "404 Not Found", "text/plain", b"a live view has no controls").await,
        },
        _ => respond(&mut s, "404 Not Found", "text/plain", b"not found").await,
    }
}

/// Reads the request head and returns its target (`/path?query`), `None` for a non-GET.
async fn read_target(s: &mut TcpStream) -> std::io::Result<Option<String>> {
    let (head, _) = super::front::read_head(s).await?;
    let text = String::from_utf8_lossy(&head);
    let mut words = text.lines().next().unwrap_or_default().split_whitespace();
    Ok(match (words.next(), words.next()) {
        (Some("GET"), Some(t)) => Some(t.to_string()),
        _ => None,
    })
}

async fn respond(s: &mut TcpStream, status: &str, ctype: &str, body: &[u8]) -> std::io::Result<()> {
    let head = format!("HTTP/1.1 {status}\r\nContent-Type: {ctype}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n", body.len());
    s.write_all(head.as_bytes()).await?;
    s.write_all(body).await?;
    s.flush().await
}

/// Streams the world, the trails so far and then every new frame as Server-Sent Events (the
/// trails again, before its frame, whenever their epoch changes).
async fn events(
    mut s: TcpStream,
    mut snap: watch::Receiver<Snapshot>,
    trails: Arc<dyn TrailSource>,
) -> std::io::Result<()> {
    s.write_all(b"HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\nConnection: keep-alive\r\n\r\n").await?;
    let mut sent = Snapshot::default();
    let mut trails_sent = None;
    loop {
        let now = snap.borrow_and_update().clone();
        if now.world.is_some() && !same(&now.world, &sent.world) {
            s.write_all(format!("event: world\ndata: {}\n\n", now.world.as_deref().unwrap_or("null")).as_bytes())
                .await?;
        }
        if trails_sent != Some(now.trails_epoch) {
            s.write_all(format!("event: trails\ndata: {}\n\n", trails.trails()).as_bytes()).await?;
            trails_sent = Some(now.trails_epoch);
        }
        if now.frame.is_some() && !same(&now.frame, &sent.frame) {
            s.write_all(format!("data: {}\n\n", now.frame.as_deref().unwrap_or("null")).as_bytes()).await?;
        }
        s.flush().await?;
        sent = now;
        if snap.changed().await.is_err() {
            return Ok(());
        }
    }
}

fn same(a: &Option<Arc<str>>, b: &Option<Arc<str>>) -> bool {
    match (a, b) {
        (Some(a), Some(b)) => Arc::ptr_eq(a, b),
        (None, None) => true,
        _ => false,
    }
}

/// `a=1&b=x` as pairs (no percent-decoding: the page sends plain words and numbers).
fn parse_query(q: &str) -> Command {
    q.split('&')
        .filter(|p| !p.is_empty())
        .map(|p| p.split_once('=').unwrap_or((p, "")))
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn queries_split_into_pairs() {
        assert_eq!(
            parse_query("cmd=seek&tick=40"),
            vec![("cmd".to_string(), "seek".to_string()), ("tick".to_string(), "40".to_string())]
        );
        assert!(parse_query("").is_empty());
    }
}
