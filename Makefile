# Convenience entry points for obs. Everything real is in CMake; this file only chains the steps.
#   make demo   install dependencies, build, run the cantilever example
#   make test   install dependencies, build, run the whole test suite
# Variables: BUILD_DIR (default build), JOBS (default: number of cores).

BUILD_DIR ?= build
JOBS ?= $(shell nproc)
DEMO_SCENE ?= data/scenes/cantilever.toml
DEMO_OUT ?= out/cantilever

# cmake --build runs make again; keep its output free of "Entering directory" lines.
MAKEFLAGS += --no-print-directory

.PHONY: all deps configure build demo test clean

all: build

deps:
	scripts/install-deps

# Configure once; later builds reuse the cache (and CMake re-runs itself when needed).
# cmake_install.cmake exists only after a successful generate step, so a failed first
# configure is retried rather than leaving a half-configured build directory behind.
configure: deps
	@if [ ! -f $(BUILD_DIR)/CMakeCache.txt ] || [ ! -f $(BUILD_DIR)/cmake_install.cmake ]; then \
	  echo "cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release"; \
	  cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release; \
	fi

build: configure
	cmake --build $(BUILD_DIR) -j$(JOBS)

demo: build
	$(BUILD_DIR)/drivers/obs run $(DEMO_SCENE) --output $(DEMO_OUT)
	@echo
	@echo "Output of $(DEMO_SCENE) is in $(DEMO_OUT)/:"
	@ls -1 $(DEMO_OUT)/*.vtu $(DEMO_OUT)/summary.json 2>/dev/null | sed 's/^/  /' || true
	@echo "  *.vtu         mesh and solution fields, e.g. displacement, stress (VTK XML, for ParaView)"
	@echo "  summary.json  summary of the run: problem size, results, times, peak memory"
	@echo "To view it: paraview $(DEMO_OUT)/*.vtu (or File > Open in ParaView), press Apply,"
	@echo "colour by a field and add Filters > Warp By Vector (displacement) to see the deformed body."

test: build
	ctest --test-dir $(BUILD_DIR) --output-on-failure -j$(JOBS)

clean:
	rm -rf $(BUILD_DIR) $(DEMO_OUT)
