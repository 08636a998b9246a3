//! `swarm-node`: the hub, an agent or agent host, or a router, and nothing else ([`swarm_node::command`]).
fn main() -> std::process::ExitCode {
    swarm_node::command::main()
}
