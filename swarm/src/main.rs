//! The `swarm` command; everything lives in the library so tests can run the same code.

/// mimalloc instead of glibc's malloc: malloc, realloc and free were 11 % of forest-1000-icp's
/// floor (`perf`), the agents' many small per-step buffers. It runs open-1000 at about its 3x
/// target for about twice the resident memory; without transparent huge pages, which took 70 %
/// more memory for forest-5's seven processes (docs/performance.md, "The allocator", has the
/// runs). Allocation never changes a result, so flights stay byte for byte the same.
#[cfg(feature = "mimalloc")]
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    swarm::cli::main()
}
