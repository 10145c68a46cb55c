# raylab entry points. Every target installs what it needs first (make deps),
# so on a fresh Debian machine with Rust, Python and git, `make demo` and
# `make test` are the only two commands needed.

CARGO ?= cargo
RAYLAB := target/release/raylab
OUT := out/demo

.PHONY: all deps build demo test bench bench-peers book clean

all: build

## deps: install what is missing (idempotent): real meshes from Debian packages,
## Embree, the book's tools, a Vulkan driver (lavapipe) for the GPU port,
## Chromium for checking the book in a browser.
deps:
	@scripts/deps

## build: release build of the library and the raylab binary.
build: deps
	$(CARGO) build --release

## demo: render the source systems' scenes, re-run S1's experiment (its
## tables and plots), and say where everything is.
demo: build
	@mkdir -p $(OUT)
	$(RAYLAB) render data/scenes/s1-spheres.toml -o $(OUT)/s1-spheres.png
	$(RAYLAB) render data/scenes/s1-spheres.toml --sampler ogss:2 -o $(OUT)/s1-spheres-ogss2.png
	$(RAYLAB) render data/scenes/camel.toml -o $(OUT)/camel.png
	$(RAYLAB) render data/scenes/camel.toml --accel embree -o $(OUT)/camel-embree.png
	$(RAYLAB) diff $(OUT)/camel-embree.png $(OUT)/camel.png
	$(RAYLAB) render data/scenes/s1-spheres.toml -o $(OUT)/s1-spheres.exr
	$(RAYLAB) render data/scenes/s1-spheres.toml --device gpu -o $(OUT)/s1-spheres-gpu.exr --reference $(OUT)/s1-spheres.exr
	$(RAYLAB) render data/scenes/cornell-box.toml -o $(OUT)/cornell-box.png
	$(RAYLAB) render data/scenes/aa/zone-plate.toml --sampler adaptive -o $(OUT)/zone-plate-adaptive.png --spp-map $(OUT)/zone-plate-adaptive-spp.png
	$(RAYLAB) render data/scenes/cornell-box.toml --integrator path:4 --sampler random:64 --accel bvh -o $(OUT)/cornell-box-path.png
	$(RAYLAB) stats data/scenes/camel.toml --width 200 --height 150 --out $(OUT)/stats-camel
	$(RAYLAB) validate --mesh data/external/cgal/camel.off --rays 20000 --out $(OUT)/validate-camel
	$(RAYLAB) experiment analysis/s1-ogss-cost.toml
	$(RAYLAB) experiment analysis/s3-bvh-ladder.toml --quick
	$(RAYLAB) experiment analysis/bvh-volumes.toml --quick
	$(RAYLAB) experiment analysis/embree-oracle.toml
	$(RAYLAB) experiment analysis/embree-speed.toml --quick
	$(RAYLAB) experiment analysis/aa-images.toml --quick
	$(RAYLAB) experiment analysis/s4-cornell.toml --quick
	@echo
	@echo "demo images are in $(OUT)/:"
	@ls -1 $(OUT)/*.png | sed 's/^/  /'
	@echo "cost heatmaps: $(OUT)/stats-camel/; Embree validation of the camel: $(OUT)/validate-camel/"
	@echo "experiments (data.csv, meta.json, figures) in analysis/out/:"
	@echo "  s1-ogss-cost (S1's tables, full), s3-bvh-ladder and bvh-volumes (S3, quick),"
	@echo "  embree-oracle (full), embree-speed and aa-images (quick); full runs: see book/src/reproducing.md"

## test: formatting and lints (cargo fmt, cargo clippy -D warnings); every
## crate's tests, including the real-mesh readers, the Embree cross-checks and
## the CLI; the API docs with no broken links; the Slurm and GNU-parallel
## scripts on a throwaway local cluster (scripts/test-slurm); then the book is
## built with the release build (figures from the quick experiments and the
## committed full runs, numbers substituted from their data) and its pages
## checked, as HTML and in headless Chromium (see book). scripts/test runs the
## steps (make deps first) and says how long each took.
test:
	@scripts/test

## book: the book (book/book/index.html): the quick experiments make its
## figures, mdBook + mdbook-katex (installed into .deps/tools when missing)
## build it, and scripts/check-book-links.py checks its links, images, maths and titles;
## scripts/check-book-browser.py then opens every page in headless Chromium and fails
## on a maths error, raw TeX, an image that did not load, a page wider than the
## window or a console error, and saves screenshots of a few pages in book/book-screenshots/.
book: build
	@scripts/book

## bench: benchmarks (release builds; print ratios measured in one run).
bench: deps
	$(CARGO) bench

## bench-peers: raylab against Mitsuba 3 (scalar and LLVM variants) on the Cornell
## box, same scene, spp and threads, timed side by side and the images' mean
## colours compared (scripts/bench-peers; installs mitsuba from PyPI into
## .deps/peers-venv on first use). Not part of test or demo. Options go in
## PEERS, e.g. make bench-peers PEERS="--spp 64 --runs 5 --threads 2 --out DIR".
PEERS ?=
bench-peers: build
	RAYLAB=$(RAYLAB) scripts/bench-peers $(PEERS)

clean:
	$(CARGO) clean
	rm -rf out analysis/out book/book book/book-screenshots book/src/figures
