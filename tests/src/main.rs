//! The `swarm` command built inside the end-to-end test package, so the tests can spawn it by
//! path (`CARGO_BIN_EXE_swarm-e2e`). Same code as the shipped `swarm` binary.
fn main() -> std::process::ExitCode {
    swarm::cli::main()
}
