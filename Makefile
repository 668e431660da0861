# Container image and local farm helpers. The Rust build itself is plain cargo.
IMAGE ?= tessera:latest
COMPOSE ?= $(shell docker compose version >/dev/null 2>&1 && echo "docker compose" || echo docker-compose)
WORKERS ?= 3
PGO ?= auto

.PHONY: image static pgo up down

# The image from the static binary: the profile-guided build (deploy/build-pgo.sh --static) where
# an llvm-profdata of rustc's LLVM is installed, else the plain one
# (target/x86_64-unknown-linux-gnu/release/tessera) with a note. PGO=1 insists on the
# profile-guided build, PGO=0 builds the plain one.
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
