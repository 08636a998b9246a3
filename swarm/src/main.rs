//! The `swarm` command; everything lives in the library so tests can run the same code.
fn main() -> std::process::ExitCode {
    swarm::cli::main()
}
