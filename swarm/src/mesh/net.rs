//! A network of machines on one Linux machine: a network namespace per machine, each with an
//! `eth0` joined by a veth pair to a bridge in a namespace of its own, addresses
//! `10.78.0.{i + 1}/24` that exist only inside these namespaces. Built with `ip` (iproute2;
//! needs root), removed when dropped, also when the study fails. The kernel counts the bytes on
//! each machine's link (`ip -s link`), which is what the study reports.

use anyhow::{bail, Context, Result};
use std::process::Command;

/// The namespaces of one network, removed with their links on drop.
pub struct Net {
    prefix: String,
    machines: Vec<String>,
    created: Vec<String>,
}

/// Runs `ip ARGS`; the error says what it printed.
fn ip(args: &[&str]) -> Result<String> {
    let out = Command::new("ip").args(args).output().context("cannot run `ip` (iproute2)")?;
    if !out.status.success() {
        bail!("`ip {}`: {}", args.join(" "), String::from_utf8_lossy(&out.stderr).trim());
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Received and sent bytes of the first interface in `ip -j -s link show DEV` output.
pub fn link_bytes_of(json: &str) -> Result<(u64, u64)> {
    let v: serde_json::Value = serde_json::from_str(json).context("`ip -j -s link` printed no JSON")?;
    let stats = &v[0]["stats64"];
    let get =
        |dir: &str| stats[dir]["bytes"].as_u64().with_context(|| format!("no {dir} bytes in `ip -j -s link`: {json}"));
    Ok((get("rx")?, get("tx")?))
}

impl Net {
    /// Builds one namespace per name of `machines` (named `<prefix>-<machine>`) on a bridge.
    pub fn build(prefix: &str, machines: &[String]) -> Result<Net> {
        let mut net = Net { prefix: prefix.to_string(), machines: machines.to_vec(), created: Vec::new() };
        let br = net.add_ns("br")?;
        ip(&["-n", &br, "link", "add", "br0", "type", "bridge"])?;
        ip(&["-n", &br, "link", "set", "br0", "up"])?;
        for (i, m) in machines.iter().enumerate() {
            let ns = net.add_ns(m)?;
            let port = format!("p{i}");
            ip(&["-n", &ns, "link", "set", "lo", "up"])?;
            ip(&["-n", &ns, "link", "add", "eth0", "type", "veth", "peer", "name", &port, "netns", &br])?;
            ip(&["-n", &br, "link", "set", &port, "master", "br0"])?;
            ip(&["-n", &br, "link", "set", &port, "up"])?;
            ip(&["-n", &ns, "addr", "add", &format!("{}/24", net.addr(m)), "dev", "eth0"])?;
            ip(&["-n", &ns, "link", "set", "eth0", "up"])?;
        }
        Ok(net)
    }

    fn add_ns(&mut self, name: &str) -> Result<String> {
        let ns = format!("{}-{name}", self.prefix);
        ip(&["netns", "add", &ns]).with_context(|| {
            format!("cannot make network namespace {ns} (`swarm mesh` needs root, or CAP_SYS_ADMIN, on Linux)")
        })?;
        self.created.push(ns.clone());
        Ok(ns)
    }

    /// The machines, in the order they were given.
    pub fn machines(&self) -> &[String] {
        &self.machines
    }

    /// The namespace of `machine`.
    pub fn ns(&self, machine: &str) -> String {
        format!("{}-{machine}", self.prefix)
    }

    /// The address of `machine` (inside the network only).
    pub fn addr(&self, machine: &str) -> String {
        let i = self.machines.iter().position(|m| m == machine).expect("a machine of this network");
        format!("10.78.0.{}", i + 1)
    }

    /// A command that runs `program ARGS` inside `machine`'s namespace.
    pub fn command(&self, machine: &str, program: &std::path::Path) -> tokio::process::Command {
        let mut c = tokio::process::Command::new("ip");
        c.args(["netns", "exec", &self.ns(machine)]).arg(program);
        c
    }

    /// Bytes received and sent on `machine`'s link so far, as the kernel counts them.
    pub fn link_bytes(&self, machine: &str) -> Result<(u64, u64)> {
        link_bytes_of(&ip(&["-n", &self.ns(machine), "-j", "-s", "link", "show", "eth0"])?)
    }
}

impl Drop for Net {
    fn drop(&mut self) {
        for ns in self.created.iter().rev() {
            if let Err(e) = ip(&["netns", "del", ns]) {
                tracing::warn!("cleanup: {e}");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn link_bytes_are_read_from_ip_json() {
        let json = r#"[{"ifname":"eth0","stats64":{"rx":{"bytes":1200,"packets":3},"tx":{"bytes":800,"packets":2}}}]"#;
        assert_eq!(link_bytes_of(json).expect("parses"), (1200, 800));
        assert!(link_bytes_of("[]").is_err());
        assert!(link_bytes_of("not json").is_err());
    }
}
