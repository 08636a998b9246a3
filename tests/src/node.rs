//! The `swarm-node` command built inside the end-to-end test package, so the tests can spawn it by
//! path (`CARGO_BIN_EXE_swarm-node-e2e`). Same code as the shipped `swarm-node` binary.
/// The shipped `swarm-node`'s allocator, so the tests run what users run (`swarm/src/main.rs`
/// says why).
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    swarm_node::command::main()
}
