//! The `swarm-node` command built inside the end-to-end test package, so the tests can spawn it by
//! path (`CARGO_BIN_EXE_swarm-node-e2e`). Same code as the shipped `swarm-node` binary.
fn main() -> std::process::ExitCode {
    swarm_node::command::main()
}
