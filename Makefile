# Container image and local farm helpers. The Rust build itself is plain cargo.
IMAGE ?= tessera:latest
COMPOSE ?= $(shell docker compose version >/dev/null 2>&1 && echo "docker compose" || echo docker-compose)
WORKERS ?= 3
PGO ?= 0

.PHONY: image static pgo up down

# The static binary (target/x86_64-unknown-linux-gnu/release/tessera) and the image from it;
# `make image PGO=1` puts the profile-guided build in the image instead.
image:
	PGO=$(PGO) deploy/build-image.sh $(IMAGE)

# A profile-guided build of tessera (target/pgo/use/…/tessera): see deploy/build-pgo.sh.
pgo:
	deploy/build-pgo.sh

static:
	RUSTFLAGS="-C target-feature=+crt-static" cargo build --release --target x86_64-unknown-linux-gnu -p tessera-server --bin tessera

# A farm on this machine: needs tessera.env (cp tessera.env.example tessera.env, set the tokens).
up: image
	TESSERA_IMAGE=$(IMAGE) $(COMPOSE) up -d --scale worker=$(WORKERS)

down:
	$(COMPOSE) down
