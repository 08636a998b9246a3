# A swarm in containers: `docker compose up` with compose.yaml beside this file (see the README,
# "Containers"). Not exercised here: no container engine runs on the machines this project is
# developed and tested on.
#
# Stage 1 builds `swarm` from the workspace (the first build takes minutes: Zenoh).
FROM rust:1.90-bookworm AS build
WORKDIR /src
COPY . .
RUN cargo build --release --locked -p swarm \
    && strip target/release/swarm

# Stage 2: a slim runtime with only the `swarm` binary (the built-in scenarios are compiled in).
FROM debian:bookworm-slim
RUN useradd --system --create-home --home-dir /data --uid 10001 swarm \
    && mkdir -p /data/runs && chown swarm /data/runs
COPY --from=build /src/target/release/swarm /usr/local/bin/swarm
USER swarm
WORKDIR /data
EXPOSE 7447
ENTRYPOINT ["swarm"]
CMD ["scenarios"]
