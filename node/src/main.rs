//! `swarm-node`: the hub, an agent or agent host, or a router, and nothing else ([`swarm_node::command`]).
/// mimalloc instead of glibc's malloc, as in `swarm` (its `main.rs` says why): the same hub and
/// agent hosts, so the same allocator.
#[cfg(feature = "mimalloc")]
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    swarm_node::command::main()
}
