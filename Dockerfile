# A swarm in containers: `docker compose up --build` with compose.yaml beside this file (see
# docs/hosts-and-containers.md, "Containers").
#
# The users' path is the default target, `runtime`: stage `build` compiles `swarm` in the Rust
# image of the workspace's `rust-version` (the first build takes minutes: Zenoh), and `runtime`
# holds only the binary (the built-in scenarios are compiled in). tools/compose-e2e, which has no
# image registry, builds target `prebuilt` instead: the same runtime around a `swarm` built on
# the host, from a context holding only this file and `target/release/swarm`, on a Debian
# bookworm base it makes with debootstrap (`--build-arg RUNTIME_BASE=...`). The classic builder
# builds every stage before its target, so `prebuilt` comes before `build`.

ARG RUNTIME_BASE=debian:bookworm-slim

# The runtime without `swarm`: an unprivileged user (uid 10001) owning the run folders and the
# credentials folder, so a named volume mounted there starts out owned by it.
FROM ${RUNTIME_BASE} AS runtime-base
RUN useradd --system --create-home --home-dir /data --uid 10001 swarm \
    && mkdir -p /data/runs /data/credentials \
    && chown swarm /data/runs /data/credentials \
    && chmod 0700 /data/credentials
USER swarm
WORKDIR /data
EXPOSE 7447
ENTRYPOINT ["swarm"]
CMD ["scenarios"]

# The runtime around a `swarm` built on the host (tools/compose-e2e).
FROM runtime-base AS prebuilt
COPY target/release/swarm /usr/local/bin/swarm

# Stage 1 of the users' path: build `swarm` from the workspace.
FROM rust:1.90-bookworm AS build
WORKDIR /src
COPY . .
RUN cargo build --release --locked -p swarm \
    && strip target/release/swarm

# Stage 2 of the users' path (the default target): the runtime with only the `swarm` binary.
FROM runtime-base AS runtime
COPY --from=build /src/target/release/swarm /usr/local/bin/swarm
