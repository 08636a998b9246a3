//! The `swarm` command built inside the end-to-end test package, so the tests can spawn it by
//! path (`CARGO_BIN_EXE_swarm-e2e`). Same code as the shipped `swarm` binary.
/// The shipped `swarm`'s allocator, so the tests run what users run (`swarm/src/main.rs` says why).
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    swarm::cli::main()
}
