# Convenience entry points for obs. Everything real is in CMake; this file only chains the steps.
#   make demo   install dependencies, build, run the main example (thesis Example 1A: adaptive punch)
#   make test   install dependencies, build, run the whole test suite
#   make sanitize  AddressSanitizer + UndefinedBehaviorSanitizer build in build-sanitize/ and the
#               whole test suite under it (manual: slow on small machines, not part of CI)
#   make docs   API reference with Doxygen (installs doxygen) into $(BUILD_DIR)/docs/html
# Variables: BUILD_DIR (default build), JOBS (default: number of cores).

BUILD_DIR ?= build
JOBS ?= $(shell nproc)
DEMO_SCENE ?= data/scenes/example1a.toml
DEMO_OUT ?= out/example1a

# cmake --build runs make again; keep its output free of "Entering directory" lines.
MAKEFLAGS += --no-print-directory

.PHONY: all deps configure build demo test sanitize docs clean

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
	$(BUILD_DIR)/drivers/obs run $(DEMO_SCENE) --output $(DEMO_OUT) --plots
	@echo
	@echo "Output of $(DEMO_SCENE) is in $(DEMO_OUT)/:"
	@ls -1 $(DEMO_OUT)/*.vtu $(DEMO_OUT)/*.png $(DEMO_OUT)/steps.csv $(DEMO_OUT)/summary.json 2>/dev/null | sed 's/^/  /' || true
	@echo "  *.vtu, *.pvd  mesh and fields of the last step: displacement, stress, contact pressure s_p,"
	@echo "                contact node class, estimator contributions (VTK XML, for ParaView)"
	@echo "  *.png         estimator vs vertices, s_p vs the exact pressure, pressure errors"
	@echo "  steps.csv     one row per adaptive step: unknowns, contact vertices, eta_1..eta_8, errors, times"
	@echo "  summary.json  summary of the run: problem size, results, times, peak memory"
	@echo "To view it: paraview $(DEMO_OUT)/*.pvd, press Apply, colour by contact_pressure or eta_5."

test: build
	ctest --test-dir $(BUILD_DIR) --output-on-failure -j$(JOBS)

# ASan + UBSan (RelWithDebInfo, -fno-omit-frame-pointer); any report fails the test that caused
# it (halt_on_error, UBSan non-recoverable). The fuzz driver skips its memory limit under ASan.
SANITIZE_DIR ?= build-sanitize
SANITIZE_FLAGS = -fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer
sanitize: deps
	cmake -S . -B $(SANITIZE_DIR) -DCMAKE_BUILD_TYPE=RelWithDebInfo \
	  "-DCMAKE_CXX_FLAGS=$(SANITIZE_FLAGS)" "-DCMAKE_C_FLAGS=$(SANITIZE_FLAGS)" \
	  "-DCMAKE_EXE_LINKER_FLAGS=$(SANITIZE_FLAGS)" "-DCMAKE_SHARED_LINKER_FLAGS=$(SANITIZE_FLAGS)" \
	  -DOBS_BUILD_BENCH=OFF
	cmake --build $(SANITIZE_DIR) -j$(JOBS)
	ASAN_OPTIONS=detect_leaks=1:halt_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
	  ctest --test-dir $(SANITIZE_DIR) --output-on-failure -j$(JOBS)
# The API reference from the header comments (Doxyfile); doxygen is needed only here, so it is
# installed by `install-deps --docs`, not by the other targets. Warnings, among them every
# undocumented public name, are listed in $(BUILD_DIR)/docs/doxygen-warnings.log.
docs:
	scripts/install-deps --docs
	rm -rf $(BUILD_DIR)/docs && mkdir -p $(BUILD_DIR)/docs
	OBS_DOCS_OUTPUT=$(BUILD_DIR)/docs doxygen Doxyfile
	@echo "API reference: $(BUILD_DIR)/docs/html/index.html"
	@echo "Doxygen warnings: $$(grep -c warning $(BUILD_DIR)/docs/doxygen-warnings.log) in $(BUILD_DIR)/docs/doxygen-warnings.log ($$(grep -c 'is not documented' $(BUILD_DIR)/docs/doxygen-warnings.log) undocumented public names)"

clean:
	rm -rf $(BUILD_DIR) $(DEMO_OUT)
