//! What every binary of the workspace does around its command, in one place so `swarm` and
//! `swarm-node` log and fail alike: tracing to standard error (`RUST_LOG`, Zenoh's own chatter at
//! warn by default, RustDDS's off: it logs a peer's every coming and going as an error; ask for
//! it with `RUST_LOG=info,rustdds=warn`), a Tokio runtime (two worker threads unless the
//! command asks otherwise, see [`run_on`]) whose error ends the process with a message, and
//! [`out`]: a line to standard output that a closed pipe (`swarm run | head`) ends quietly
//! instead of panicking as `println!` does.

use std::future::Future;
use std::process::ExitCode;

/// Prints `line` and a newline to standard output. A reader that went away (a closed pipe) is
/// no error: the process goes on, printing nothing more; any other failure is said on stderr.
pub fn out(line: &str) {
    use std::io::Write;
    let mut o = std::io::stdout().lock();
    match o.write_all(line.as_bytes()).and_then(|()| o.write_all(b"\n")).and_then(|()| o.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => eprintln!("cannot write to standard output: {e}"),
        _ => {}
    }
}

/// The runtime's worker threads unless the command asks otherwise.
pub const DEFAULT_WORKERS: usize = 2;

/// [`run_on`] with [`DEFAULT_WORKERS`].
pub fn run<F>(command: F) -> ExitCode
where
    F: Future<Output = anyhow::Result<ExitCode>>,
{
    run_on(DEFAULT_WORKERS, command)
}

/// Sets up logging, runs `command` on a runtime of `workers` worker threads (at least one),
/// prints its error as `error: …` and turns it into a failing exit code.
pub fn run_on<F>(workers: usize, command: F) -> ExitCode
where
    F: Future<Output = anyhow::Result<ExitCode>>,
{
    init_tracing();
    let rt = match tokio::runtime::Builder::new_multi_thread().worker_threads(workers.max(1)).enable_all().build() {
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
