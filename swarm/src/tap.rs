//! `swarm tap KEYEXPR`: print every sample on a key expression as one JSON line, decoded from
//! postcard, so people inspecting the key space need none of our code. Payloads that are not a
//! [`Msg`] are printed as text when they are UTF-8 (the scenario queryable answers TOML), else as
//! a byte count with the decode error.
//!
//! `swarm put KEY`: the other direction, for poking a live run: publish a message written as the
//! JSON that `tap` prints (`{"Cmd": {...}}`), or raw bytes in hex (to see a malformed payload
//! counted and dropped), once or repeated as a flood (`--repeat`, `--every-ms`).

use anyhow::{anyhow, Result};
use clap::Args;
use serde_json::{json, Value};
use std::process::ExitCode;
use std::time::Duration;
use swarm_wire::plumbing;
use swarm_wire::{Msg, WireError};
use zenoh::qos::CongestionControl;

/// `swarm tap`.
#[derive(Args, Debug, Clone)]
pub struct TapArgs {
    /// Key expression, e.g. `swarm/my-run/uav/3/**` or `swarm/*/truth/step`.
    pub keyexpr: String,
    /// Endpoints.
    #[command(flatten)]
    pub zenoh: swarm_args::ZenohArgs,
    /// Stop after this many messages.
    #[arg(long)]
    pub count: Option<u64>,
    /// Stop after this many seconds.
    #[arg(long)]
    pub duration: Option<f64>,
    /// Query (`get`) instead of subscribing: for queryables such as `swarm/{run}/scenario`.
    #[arg(long)]
    pub get: bool,
    /// Watch liveliness tokens instead of data, e.g. `swarm/{run}/alive/**`.
    #[arg(long)]
    pub alive: bool,
}

/// `swarm put`.
#[derive(Args, Debug, Clone)]
pub struct PutArgs {
    /// Key, e.g. `swarm/my-run/uav/3/cmd`.
    pub key: String,
    /// The message as JSON, in the shape `tap` prints under "msg", e.g. `{"Cmd": {...}}`.
    #[arg(long, conflicts_with = "hex", required_unless_present = "hex")]
    pub json: Option<String>,
    /// Raw payload bytes in hex, sent as they are.
    #[arg(long)]
    pub hex: Option<String>,
    /// Publish the payload this many times (0: until stopped), for floods of bad input.
    #[arg(long, default_value_t = 1)]
    pub repeat: u64,
    /// Milliseconds between two publications when repeating.
    #[arg(long, default_value_t = 1)]
    pub every_ms: u64,
    /// Endpoints.
    #[command(flatten)]
    pub zenoh: swarm_args::ZenohArgs,
}

fn parse_hex(h: &str) -> Result<Vec<u8>> {
    let h: String = h.chars().filter(|c| !c.is_whitespace()).collect();
    anyhow::ensure!(h.len().is_multiple_of(2), "--hex: odd number of digits");
    (0..h.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&h[i..i + 2], 16).map_err(|e| anyhow!("--hex: {e} at digit {i}")))
        .collect()
}

/// Runs `swarm put`.
pub async fn put(a: PutArgs) -> Result<ExitCode> {
    anyhow::ensure!(!a.zenoh.connect.is_empty(), "put needs --connect <hub endpoint>");
    let bytes = match (&a.json, &a.hex) {
        (Some(j), _) => {
            let m: Msg = serde_json::from_str(j).map_err(|e| anyhow!("--json is not a message: {e}"))?;
            m.encode()?
        }
        (None, Some(h)) => parse_hex(h)?,
        (None, None) => anyhow::bail!("give --json or --hex"),
    };
    let s = a.zenoh.open_tool_session().await?;
    if a.repeat == 1 {
        // Zenoh's default for a put: dropped rather than blocking under congestion.
        plumbing::put_once(&s, &a.key, bytes, CongestionControl::Drop).await?;
    } else {
        flood(&s, &a, bytes).await?;
    }
    let _ = s.close().await;
    Ok(ExitCode::SUCCESS)
}

/// Publishes `bytes` `a.repeat` times (0: until killed), one every `a.every_ms`, dropped rather
/// than blocking under congestion; logs how many went out every 1000.
async fn flood(s: &zenoh::Session, a: &PutArgs, bytes: Vec<u8>) -> Result<()> {
    let p = s
        .declare_publisher(a.key.clone())
        .congestion_control(CongestionControl::Drop)
        .await
        .map_err(WireError::zenoh)?;
    let mut tick = tokio::time::interval(Duration::from_millis(a.every_ms.max(1)));
    let mut sent = 0u64;
    while a.repeat == 0 || sent < a.repeat {
        tick.tick().await;
        p.put(bytes.clone()).await.map_err(WireError::zenoh)?;
        sent += 1;
        if sent.is_multiple_of(1000) {
            tracing::info!(sent, key = %a.key, "flooding");
        }
    }
    Ok(())
}

/// Decodes one payload into a JSON value (never fails: undecodable payloads are described).
pub fn describe(key: &str, encoding: &str, bytes: &[u8]) -> Value {
    match Msg::decode(bytes) {
        Ok(m) => json!({ "key": key, "encoding": encoding, "kind": m.kind(), "msg": m }),
        Err(e) => match std::str::from_utf8(bytes) {
            Ok(text) => json!({ "key": key, "encoding": encoding, "text": text }),
            Err(_) => json!({ "key": key, "encoding": encoding, "bytes": bytes.len(), "error": e.to_string() }),
        },
    }
}

/// Runs `swarm tap`.
pub async fn tap(a: TapArgs) -> Result<ExitCode> {
    anyhow::ensure!(!a.zenoh.connect.is_empty(), "tap needs --connect <hub endpoint>");
    let s = a.zenoh.open_tool_session().await?;
    let limit = a.count.unwrap_or(u64::MAX);
    let mut printed = 0u64;
    // Stop quietly when the reader goes away (`swarm tap ... | head`): no panic on a broken pipe.
    let mut print = |v: Value| {
        use std::io::Write;
        let mut out = std::io::stdout().lock();
        if writeln!(out, "{v}").and_then(|()| out.flush()).is_err() {
            return false;
        }
        printed += 1;
        printed < limit
    };
    if a.get {
        query(&s, &a.keyexpr, &mut print).await?;
    } else {
        follow(&s, &a, &mut print).await?;
    }
    let _ = s.close().await;
    if printed == 0 {
        eprintln!("{}", nothing_came(&a));
    }
    Ok(ExitCode::SUCCESS)
}

/// What a tap that got nothing says: the hub's router drops a subscription a login may not
/// make without a word to the client, so an empty tap may be the role's doing, not silence.
fn nothing_came(a: &TapArgs) -> String {
    let within = a.duration.map_or(String::new(), |d| format!(" within {d} s"));
    let who = match &a.zenoh.user {
        Some(u) => format!("as {u:?}"),
        None => "without a login".to_string(),
    };
    format!(
        "nothing came on {}{within}. Either nothing was published there, or the hub's router refused the subscription: \
         it gives each login only its role's keys and drops the rest without telling the client ({who}; an agent `uav3` \
         reads only its own sensors, never another UAV's or truth/**; `--user observer` reads every key: docs/security.md)",
        a.keyexpr
    )
}

/// `swarm tap --get`: prints every reply to one query, while `print` wants more.
async fn query(s: &zenoh::Session, keyexpr: &str, print: &mut dyn FnMut(Value) -> bool) -> Result<()> {
    let replies = s.get(keyexpr).timeout(Duration::from_secs(5)).await.map_err(WireError::zenoh)?;
    while let Ok(r) = replies.recv_async().await {
        let v = match r.result() {
            Ok(sm) => describe(sm.key_expr().as_str(), &sm.encoding().to_string(), &sm.payload().to_bytes()),
            Err(e) => json!({ "error": String::from_utf8_lossy(&e.payload().to_bytes()) }),
        };
        if !print(v) {
            break;
        }
    }
    Ok(())
}

/// Prints the samples (or, with `--alive`, liveliness changes) on the tap's key expression until
/// `--duration`, Ctrl-C, or `print` wants no more.
async fn follow(s: &zenoh::Session, a: &TapArgs, print: &mut dyn FnMut(Value) -> bool) -> Result<()> {
    let deadline = a.duration.map(|d| tokio::time::Instant::now() + Duration::from_secs_f64(d));
    // A ring buffer never pushes back: a tap whose reader stalls (a pager, a full pipe) drops
    // its oldest samples instead of stalling a lockstep run, whose publishers block.
    let ring = || zenoh::handlers::RingChannel::new(4096);
    let sub = if a.alive {
        s.liveliness().declare_subscriber(&a.keyexpr).history(true).with(ring()).await.map_err(WireError::zenoh)?
    } else {
        s.declare_subscriber(&a.keyexpr).with(ring()).await.map_err(WireError::zenoh)?
    };
    // Scripts (and tests) that must not miss the first samples wait for this line on stderr.
    tracing::info!(keyexpr = %a.keyexpr, "tap listening");
    loop {
        let next = async {
            match deadline {
                Some(d) => tokio::time::timeout_at(d, sub.recv_async()).await.ok(),
                None => Some(sub.recv_async().await),
            }
        };
        let sample = tokio::select! {
            r = next => match r { Some(Ok(sm)) => sm, _ => break },
            _ = tokio::signal::ctrl_c() => break,
        };
        let v = if a.alive {
            json!({ "key": sample.key_expr().as_str(), "alive": sample.kind() == zenoh::sample::SampleKind::Put })
        } else {
            describe(sample.key_expr().as_str(), &sample.encoding().to_string(), &sample.payload().to_bytes())
        };
        if !print(v) {
            break;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn describes_messages_text_and_garbage() {
        let cmd =
            Msg::Cmd(swarm_wire::Cmd { tick: 1, kind: swarm_wire::CmdKind::Hover, x: 0.0, y: 0.0, yaw_rate: 0.0 });
        let v = describe("k", "e", &cmd.encode().expect("encodes"));
        assert_eq!(v["kind"], "cmd");
        assert_eq!(v["msg"]["Cmd"]["tick"], 1);
        let v = describe("k", "e", b"name = \"x\"");
        assert_eq!(v["text"], "name = \"x\"");
        let v = describe("k", "e", &[0xff, 0xfe, 0x80]);
        assert_eq!(v["bytes"], 3);
        assert!(v["error"].is_string());
    }

    #[test]
    fn json_written_like_tap_output_is_a_message() {
        let m: Msg =
            serde_json::from_str(r#"{"Cmd": {"tick": 3, "kind": "Hover", "x": 0.0, "y": 0.0, "yaw_rate": 0.0}}"#)
                .expect("parses");
        assert_eq!(m.kind(), "cmd");
        assert_eq!(parse_hex("ff 00 1a").expect("hex"), vec![0xff, 0x00, 0x1a]);
        assert!(parse_hex("abc").is_err());
        assert!(parse_hex("zz").is_err());
    }
}
