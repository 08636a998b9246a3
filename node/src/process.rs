//! What every binary of the workspace does around its command, in one place so `swarm` and
//! `swarm-node` log and fail alike: tracing to standard error (`RUST_LOG`, Zenoh's own chatter at
//! warn by default, RustDDS's off: it logs a peer's every coming and going as an error; ask for
//! it with `RUST_LOG=info,rustdds=warn`) and a two-thread Tokio runtime whose error ends the
//! process with a message.

use std::future::Future;
use std::process::ExitCode;

/// Sets up logging, runs `command` on a two-worker runtime, prints its error as `error: …` and
/// turns it into a failing exit code.
pub fn run<F>(command: F) -> ExitCode
where
    F: Future<Output = anyhow::Result<ExitCode>>,
{
    init_tracing();
    let rt = match tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build() {
        Ok(rt) => rt,
        Err(e) => {
            eprintln!("error: cannot start the async runtime: {e}");
            return ExitCode::FAILURE;
        }
    };
    let code = match rt.block_on(command) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    };
    // Do not wait for the blocking thread that may still be reading stdin.
    rt.shutdown_timeout(std::time::Duration::from_millis(200));
    code
}

fn init_tracing() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info,zenoh=warn,zenoh_transport=warn,rustdds=off"));
    use std::io::IsTerminal;
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .try_init();
}
