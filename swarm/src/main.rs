//! The `swarm` command; everything lives in the library so tests can run the same code.

/// mimalloc instead of glibc's malloc (without transparent huge pages: with them forest-5's seven
/// processes took 70 % more resident memory instead of 15 %): malloc, realloc and free were 11 % of
/// forest-1000-icp's floor (`perf`), the agents' many small per-step buffers. Alternated in one
/// session (`swarm scale`), open-1000 ran at 3.08x and 3.01x against 2.83x and 2.62x, for about
/// twice the resident memory (447 against 200 MiB); docs/performance.md, "The allocator".
/// Allocation never changes a result, so flights stay byte for byte the same.
#[cfg(feature = "mimalloc")]
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    swarm::cli::main()
}
