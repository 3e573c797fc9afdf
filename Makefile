# The two commands the README opens with, plus a few conveniences.
.PHONY: render test test-isas test-client test-cluster deps bench-rays fmt lint

deps:
	./scripts/install-deps.sh

# Render the measured Cornell box to out/cornell-box.exr and out/cornell-box.png.
render: deps
	cargo run --release -- render scenes/cornell-box.toml -o out/cornell-box.exr --png

# The whole test suite (unit, statistical and image tests).
test: deps
	cargo test --release --workspace

# The Embree-facing tests under every Embree kernel this CPU has below its best (CI runs it).
test-isas: deps
	./scripts/test-isas.sh

# colour-science and OpenImageIO (Python, in a venv under target/) read our spectral EXRs.
test-client: deps
	./scripts/test-spectral-client.sh

# stokes submit slurm against a single-node Slurm on loopback (scripts/slurm-local.sh; needs
# root and Debian's slurm-wlm and munge): started, tests run, stopped even if they fail.
test-cluster: deps
	cargo build --release
	scripts/slurm-local.sh start >/dev/null
	. $${SLURM_LOCAL_ENV:-/tmp/stokes-slurm-local.env} && STOKES_CLUSTER=1 \
	    cargo test --release --test cluster -- --test-threads=1; \
	    rc=$$?; scripts/slurm-local.sh stop; exit $$rc

bench-rays: deps
	cargo run --release -- bench rays scenes/sphere-100k.toml
	cargo run --release -- bench rays scenes/cornell-box.toml

fmt:
	cargo fmt --all

lint:
	cargo clippy --release --all-targets -- -D warnings
