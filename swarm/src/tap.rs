//! `swarm tap KEYEXPR`: print every sample on a key expression as one JSON line, decoded from
//! postcard, so people inspecting the key space need none of our code. Payloads that are not a
//! [`Msg`] are printed as text when they are UTF-8 (the scenario queryable answers TOML), else as
//! a byte count with the decode error.

use anyhow::{anyhow, Result};
use clap::Args;
use serde_json::{json, Value};
use std::process::ExitCode;
use std::time::Duration;
use swarm_wire::session::{self, Role};
use swarm_wire::Msg;

/// `swarm tap`.
#[derive(Args, Debug, Clone)]
pub struct TapArgs {
    /// Key expression, e.g. `swarm/my-run/uav/3/**` or `swarm/*/truth/step`.
    pub keyexpr: String,
    /// Endpoints.
    #[command(flatten)]
    pub zenoh: crate::cli::ZenohArgs,
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
    let s = session::open(Role::Client, &[], &a.zenoh.connect, &a.zenoh.cfg).await?;
    let z = |e: zenoh::Error| anyhow!("zenoh: {e}");
    let deadline = a.duration.map(|d| tokio::time::Instant::now() + Duration::from_secs_f64(d));
    let limit = a.count.unwrap_or(u64::MAX);
    let mut printed = 0u64;
    let mut print = |v: Value| {
        println!("{v}");
        printed += 1;
        printed < limit
    };
    if a.get {
        let replies = s.get(&a.keyexpr).timeout(Duration::from_secs(5)).await.map_err(z)?;
        while let Ok(r) = replies.recv_async().await {
            let v = match r.result() {
                Ok(sm) => describe(sm.key_expr().as_str(), &sm.encoding().to_string(), &sm.payload().to_bytes()),
                Err(e) => json!({ "error": String::from_utf8_lossy(&e.payload().to_bytes()) }),
            };
            if !print(v) {
                break;
            }
        }
    } else {
        let sub = if a.alive {
            s.liveliness().declare_subscriber(&a.keyexpr).history(true).await.map_err(z)?
        } else {
            s.declare_subscriber(&a.keyexpr).await.map_err(z)?
        };
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
    }
    let _ = s.close().await;
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn describes_messages_text_and_garbage() {
        let cmd = Msg::Cmd(swarm_wire::Cmd { tick: 1, kind: swarm_wire::CmdKind::Hover, x: 0.0, y: 0.0, yaw_rate: 0.0 });
        let v = describe("k", "e", &cmd.encode().expect("encodes"));
        assert_eq!(v["kind"], "cmd");
        assert_eq!(v["msg"]["Cmd"]["tick"], 1);
        let v = describe("k", "e", b"name = \"x\"");
        assert_eq!(v["text"], "name = \"x\"");
        let v = describe("k", "e", &[0xff, 0xfe, 0x80]);
        assert_eq!(v["bytes"], 3);
        assert!(v["error"].is_string());
    }
}
