# deltamap — build, test, demo, bench.  `make help` lists the targets.
#
#   make deps            install the Debian packages the project needs (idempotent)
#   make / make all      build build/deltamap
#   make test            deps + build + unit tests (cmocka, under every kernel path
#                        the CPU has) + CLI, path, store, shard tests
#                        + shapes (VTK read-back, pictures) and the map explorer
#                        in headless Chromium
#                        + a sweep as a job array on a real Slurm started here
#   make test SANITIZE=1 the same built with -fsanitize=address,undefined (unit
#                        suites on the best kernel path, test_arrow on each)
#   make demo            deps + build + run the main job on a built-in robot
#   make bench           speed and memory figures
#   make test-arm64      cross-build for aarch64, run the tests under qemu-user (docs/arm64.md)
#   make fuzz            build the libFuzzer targets (clang) into build/fuzz/
#   make fuzz-run        run each fuzz target FUZZ_SECONDS (600) with ASan/UBSan
#   make install         install to $(PREFIX)/bin (PREFIX=/usr/local)

CC      ?= cc
PREFIX  ?= /usr/local
PKGS    := openblas lapacke inih jansson cminpack
PKG_CONFIG ?= pkg-config

# The sanitized build keeps -O2: the same checks, and the numeric tests run
# a quarter faster than at -O1 (chen2018's truncation figure: 49 s -> 37 s),
# which keeps CI's second pass inside its time.
ifeq ($(SANITIZE),1)
BUILD   := build/sanitize
OPT     := -O2 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=undefined
else
BUILD   := build
OPT     := -O2 -g
endif

CFLAGS  ?=
CFLAGS  += -std=c11 -D_POSIX_C_SOURCE=200809L -D_DEFAULT_SOURCE $(OPT) -Wall -Wextra -fopenmp -Iinclude
LDLIBS  := -lm
PKG_CFLAGS = $(shell $(PKG_CONFIG) --cflags $(PKGS) 2>/dev/null)
PKG_LIBS   = $(shell $(PKG_CONFIG) --libs $(PKGS) 2>/dev/null)
SUNDIALS_LIBS := -lsundials_cvode -lsundials_nvecserial

# src/ holds one folder per layer (docs/architecture.md), lowest first; a
# file may include headers of its own layer and those below, never above
# (tests/layers.sh, run before the library is archived).
LAYERS  := base robot model solve responses maps measure cli
LIB_SRC := $(filter-out src/cli/main.c,$(wildcard $(patsubst %,src/%/*.c,$(LAYERS))))
# The kernels (src/LAYER/*_kernels.c, include/dm_isa.h) are compiled as they
# are, the target's baseline path, and on x86-64 once more per path below,
# each with the registers of its instruction set; the process runs one.
TARGET_MACHINE := $(shell $(CC) -dumpmachine 2>/dev/null)
ifneq ($(filter x86_64%,$(TARGET_MACHINE)),)
ISA_PATHS := avx2 avx512
endif
ISA_FLAGS_avx2   := -mavx2
ISA_FLAGS_avx512 := -mavx512f
KERNEL_SRC := $(wildcard $(patsubst %,src/%/*_kernels.c,$(LAYERS)))
isa_objs = $(foreach p,$(ISA_PATHS),$(patsubst src/%.c,$(1)/obj/%.$(p).o,$(KERNEL_SRC)))
LIB_OBJ := $(patsubst src/%.c,$(BUILD)/obj/%.o,$(LIB_SRC)) $(call isa_objs,$(BUILD)) \
           $(BUILD)/obj/presets.o
ALL_SRC := $(wildcard $(patsubst %,src/%/*.[ch],$(LAYERS))) $(wildcard include/*.h)
TESTS   := $(patsubst tests/%.c,%,$(wildcard tests/test_*.c))
TEST_BIN:= $(addprefix $(BUILD)/tests/,$(TESTS))
BIN     := $(BUILD)/deltamap

.PHONY: all deps test test-arm64 unit-tests cli-tests isa-tests store-tests shard-tests alloc-tests slurm-tests fuzz-replay \
        shapes-tests browser-tests \
        fault-tests demo bench install clean help fuzz fuzz-deps fuzz-run
.DELETE_ON_ERROR:

all: $(BIN)

help:
	@sed -n '1,17p' Makefile | sed 's/^# \{0,1\}//'

deps:
	@tools/install-deps.sh

# -MMD -MP: each object depends on the headers it includes (public and
# the private ones beside the sources), recorded in its .d file.
$(BUILD)/obj/%.o: src/%.c | $(BUILD)/obj
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) $(PKG_CFLAGS) -MMD -MP -c $< -o $@

# The kernels never read errno: without it GCC keeps each sqrt scalar
# (a library call for errno's sake) in loops it would vectorise; sqrt's
# values are IEEE's either way, so every path keeps the same bits.
$(BUILD)/obj/%_kernels.o $(BUILD)/obj/%_kernels.avx2.o $(BUILD)/obj/%_kernels.avx512.o: CFLAGS += -fno-math-errno

# a kernel built for path $(1) (avx2, avx512)
define isa_rule
$$(BUILD)/obj/%.$(1).o: src/%.c | $$(BUILD)/obj
	@mkdir -p $$(@D)
	$$(CC) $$(CFLAGS) $$(PKG_CFLAGS) $$(ISA_FLAGS_$(1)) -DDM_ISA_PATH=$(1) -MMD -MP -c $$< -o $$@

$$(FUZZ_DIR)/obj/%.$(1).o: src/%.c $$(ALL_SRC) | $$(FUZZ_DIR)/obj
	@mkdir -p $$(@D)
	$$(FUZZ_CC) $$(FUZZ_CFLAGS) -fsanitize=fuzzer-no-link $$(PKG_CFLAGS) $$(ISA_FLAGS_$(1)) \
	    -DDM_ISA_PATH=$(1) -c $$< -o $$@
endef

# The layering, checked whenever a source or header changes.
$(BUILD)/layers.ok: $(ALL_SRC) tests/layers.sh | $(BUILD)/obj
	@tests/layers.sh >/dev/null || tests/layers.sh
	@touch $@

# The presets are the shipped robots/*.ini, compiled in as strings.
$(BUILD)/presets.c: $(wildcard robots/*.ini) tools/embed-presets.sh | $(BUILD)/obj
	tools/embed-presets.sh robots/*.ini > $@

$(BUILD)/obj/presets.o: $(BUILD)/presets.c
	$(CC) $(CFLAGS) -c $< -o $@

# Made afresh: a module renamed or removed leaves no stale member behind.
$(BUILD)/libdeltamap.a: $(LIB_OBJ) $(BUILD)/layers.ok
	rm -f $@
	$(AR) rcs $@ $(LIB_OBJ)

$(BIN): $(BUILD)/obj/cli/main.o $(BUILD)/libdeltamap.a
	$(CC) $(CFLAGS) $^ -o $@ $(PKG_LIBS) $(SUNDIALS_LIBS) $(LDLIBS)

$(BUILD)/tests/%: tests/%.c $(BUILD)/libdeltamap.a | $(BUILD)/tests
	$(CC) $(CFLAGS) $(PKG_CFLAGS) -MMD -MP -Itests $< -o $@ $(BUILD)/libdeltamap.a \
	    $(PKG_LIBS) $(SUNDIALS_LIBS) -lcmocka $(LDLIBS)

$(BUILD)/obj $(BUILD)/tests:
	mkdir -p $@

-include $(wildcard $(BUILD)/obj/*/*.d $(BUILD)/tests/*.d)

# Tests run single-threaded BLAS inside, OpenMP as the test chooses; each
# under every kernel path this CPU has (DELTAMAP_ISA, dm_isa.h), which
# `deltamap --version` lists: two runs at a time (most are single-threaded),
# each run's output shown whole when it ends (build/tests/runs/T.PATH.log).
ISA_HERE = $(shell $(BIN) --version 2>/dev/null | sed -n 's/^paths on this CPU: //p')
# Under the sanitizers (CI's second pass) the suites run on the best path
# only, but test_arrow, which calls every path's kernels side by side, on
# each: the same code under ASan/UBSan in a third of the time.
ifeq ($(SANITIZE),1)
UNIT_RUNS = $(sort $(patsubst %,$(BUILD)/tests/runs/%.$(lastword $(ISA_HERE)).ok,$(TESTS)) \
            $(foreach p,$(ISA_HERE),$(BUILD)/tests/runs/test_arrow.$(p).ok))
else
UNIT_RUNS = $(foreach p,$(ISA_HERE),$(patsubst %,$(BUILD)/tests/runs/%.$(p).ok,$(TESTS)))
endif
unit-tests: $(TEST_BIN) $(BIN)
	@test -n "$(ISA_HERE)" || { echo "unit-tests: $(BIN) --version lists no kernel path"; exit 1; }
	@rm -rf $(BUILD)/tests/runs && mkdir -p $(BUILD)/tests/runs
	@$(MAKE) --no-print-directory -j2 -k $(UNIT_RUNS)

$(BUILD)/tests/runs/%.ok: | $(BUILD)/tests
	@t=$(BUILD)/tests/$(basename $*); isa=$(patsubst .%,%,$(suffix $*)); log=$(@:.ok=.log); \
	if DELTAMAP_ISA=$$isa OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $$t >$$log 2>&1; then \
	    { echo "== $$t (DELTAMAP_ISA=$$isa)"; cat $$log; } && touch $@; \
	else { echo "== $$t (DELTAMAP_ISA=$$isa)"; cat $$log; echo "FAIL: $$t under DELTAMAP_ISA=$$isa"; \
	    exit 1; }; fi

cli-tests: $(BIN)
	@DELTAMAP=$(BIN) tests/cli_doc.sh
	@DELTAMAP=$(BIN) tests/cli_tests.sh

isa-tests: $(BIN)
	@DELTAMAP=$(BIN) tests/isa_tests.sh

store-tests: $(BIN)
	@DELTAMAP=$(BIN) tests/store_tests.sh

# A finished store, one file damaged, then info and the resume
# (tests/store_damage.py): issue 38's nine damages, then a seeded random
# damage per round for STORE_DAMAGE_SECONDS; `make fuzz-run` runs it for
# FUZZ_SECONDS with a seed of the moment (printed, with each finding's round).
STORE_DAMAGE_SECONDS ?= 50
.PHONY: store-damage fuzz-store-damage
store-damage: $(BIN)
	@.venv/bin/python tests/store_damage.py $(BIN) replay
	@.venv/bin/python tests/store_damage.py $(BIN) fuzz --seed 38 --seconds $(STORE_DAMAGE_SECONDS)
fuzz-store-damage: $(BIN)
	@.venv/bin/python tests/store_damage.py $(BIN) fuzz --seed $$(date +%s) --seconds $(FUZZ_SECONDS)
fuzz-run: fuzz-store-damage

shard-tests: $(BIN)
	@DELTAMAP=$(BIN) tests/shard_tests.sh

# Shapes for viewers (docs/shapes.md): the .vtu/.pvd read back by VTK,
# bad input (tests/shapes_tests.py; a few seconds).
shapes-tests: $(BIN)
	@.venv/bin/python tests/shapes_tests.py $(BIN)

# The map explorer's page in headless Chromium (tests/browser_tests.py,
# ~15 s). Without Chromium (make deps installs it where it can): SKIPPED
# (exit 77), which `make test` reports as such, never as passed.
browser-tests: $(BIN)
	@rm -f $(BUILD)/browser-skipped; .venv/bin/python tests/browser_tests.py $(BIN); rc=$$?; \
	if [ $$rc -eq 77 ]; then touch $(BUILD)/browser-skipped; else exit $$rc; fi

# The per-pose paths allocate nothing (tests/alloc_tests.sh): every
# allocation counted by an LD_PRELOAD shim, which the sanitizers' own
# allocator rules out under SANITIZE=1 (the script then says SKIPPED).
$(BUILD)/tests/count_alloc.so: tests/count_alloc.c | $(BUILD)/tests
	$(CC) -std=c11 -D_GNU_SOURCE -O2 -Wall -Wextra -fPIC -shared $< -o $@
ifeq ($(SANITIZE),1)
alloc-tests: $(BIN)
	@DELTAMAP=$(BIN) tests/alloc_tests.sh
else
alloc-tests: $(BIN) $(BUILD)/tests/count_alloc.so
	@DELTAMAP=$(BIN) ALLOC_SHIM=$(BUILD)/tests/count_alloc.so tests/alloc_tests.sh
endif

# Its own munged, slurmctld and slurmd, stopped by pid when done. Without
# the Slurm packages (make deps installs them) or root: SKIPPED (exit 77),
# which `make test` reports as such, never as passed.
slurm-tests: $(BIN)
	@rm -f $(BUILD)/slurm-skipped; DELTAMAP=$(BIN) tests/slurm_tests.sh; rc=$$?; \
	if [ $$rc -eq 77 ]; then touch $(BUILD)/slurm-skipped; else exit $$rc; fi

test: deps
	@tests/layers.sh
	@$(MAKE) --no-print-directory unit-tests cli-tests isa-tests store-tests store-damage shard-tests \
	    shapes-tests browser-tests alloc-tests slurm-tests fuzz-replay fault-tests
	@if [ -e $(BUILD)/slurm-skipped ]; then \
	    echo "all tests passed but the Slurm test, which was SKIPPED (see above)"; \
	else echo "all tests passed"; fi
	@if [ -e $(BUILD)/browser-skipped ]; then \
	    echo "(the browser test was SKIPPED: no chromium, see above)"; fi

# The main job on a built-in robot: the mode table at the centre, then a
# workspace sweep into maps/demo (resumable), its maps as PNG and in the
# browser (maps/demo-plots/maps.html) and the mode shapes at the centre
# (PNG grid, GIF of mode 1).
demo: deps
	@$(MAKE) --no-print-directory $(BIN)
	$(BIN) modes --robot chen2018 --at 0,0,-0.5 --modes 10
	$(BIN) sweep --robot chen2018 --grid "x=-0.4:0.4:41,y=-0.4:0.4:41,z=-0.7:-0.4:2" --out maps/demo
	$(BIN) info maps/demo
	.venv/bin/python tools/plot_maps.py maps/demo --out maps/demo-plots
	.venv/bin/python tools/plot_modes.py --robot chen2018 --at 0,0,-0.5 --out maps/demo-plots/modes.png \
	    --gif maps/demo-plots/mode1.gif
	.venv/bin/python tools/explore_maps.py maps/demo --out maps/demo-plots/maps.html

# aarch64: the library, CLI and unit tests cross-built through this Makefile
# and run under qemu-aarch64, then the CLI tests (docs/arm64.md; not in
# `make test`: the emulated suites take far longer than CI's budget).
# ARM64_FLAGS: the script's options, e.g. --no-cli or --skip "test_diagnose".
test-arm64:
	@tools/test-arm64.sh $(ARM64_FLAGS)

bench: deps
	@$(MAKE) --no-print-directory $(BUILD)/tests/bench $(BIN)
	DELTAMAP=$(BIN) $(BUILD)/tests/bench $(BENCH)

$(BUILD)/tests/bench: tests/bench.c $(BUILD)/libdeltamap.a | $(BUILD)/tests
	$(CC) $(CFLAGS) $(PKG_CFLAGS) -Itests $< -o $@ $(BUILD)/libdeltamap.a \
	    $(PKG_LIBS) $(SUNDIALS_LIBS) $(LDLIBS)

# ---- fuzzing (tests/fuzz/README.md) ------------------------------------------
# Each target tests/fuzz/fuzz_T.c is built twice: with libFuzzer (clang,
# ASan/UBSan, coverage) by `make fuzz`, and with tests/fuzz/replay.c and the
# normal compiler by `make test`, which replays every file of tests/fuzz/T/.
FUZZ_TARGETS := robot grid path path_csv measure store
FUZZ_SRC     := tests/fuzz/fuzz_util.c
FUZZ_HDR     := tests/fuzz/fuzz.h
REPLAY_BIN   := $(addprefix $(BUILD)/fuzz/replay-,$(FUZZ_TARGETS))

$(BUILD)/fuzz/replay-%: tests/fuzz/fuzz_%.c tests/fuzz/replay.c $(FUZZ_SRC) $(FUZZ_HDR) \
        $(BUILD)/libdeltamap.a | $(BUILD)/fuzz
	$(CC) $(CFLAGS) $(PKG_CFLAGS) -Isrc/cli -Itests/fuzz $< tests/fuzz/replay.c $(FUZZ_SRC) -o $@ \
	    $(BUILD)/libdeltamap.a $(PKG_LIBS) $(SUNDIALS_LIBS) $(LDLIBS)

# (the library's messages about the bad inputs are shown only when one fails)
fuzz-replay: $(REPLAY_BIN)
	@for t in $(FUZZ_TARGETS); do \
	    if $(BUILD)/fuzz/replay-$$t tests/fuzz/$$t 2>$(BUILD)/fuzz/replay-$$t.log; then \
	        tail -1 $(BUILD)/fuzz/replay-$$t.log; \
	    else cat $(BUILD)/fuzz/replay-$$t.log; echo "FAIL: fuzz replay $$t"; exit 1; fi; \
	done

# ---- fault injection (tests/fault_tests.sh) ------------------------------------
# deltamap whose allocations can be made to fail (tests/fault_alloc.c), and
# an LD_PRELOAD shim whose write/rename fail with ENOSPC (tests/fault_write.c).
$(BUILD)/tests/deltamap-faultinj: tests/fault_alloc.c $(BUILD)/libdeltamap.a | $(BUILD)/tests
	$(CC) $(CFLAGS) $(PKG_CFLAGS) $< -o $@ -Wl,--wrap=malloc,--wrap=calloc,--wrap=realloc \
	    $(BUILD)/libdeltamap.a $(PKG_LIBS) $(SUNDIALS_LIBS) $(LDLIBS)

$(BUILD)/tests/fault_write.so: tests/fault_write.c | $(BUILD)/tests
	$(CC) -std=c11 -D_GNU_SOURCE -O2 -Wall -Wextra -fPIC -shared $< -o $@ -ldl

# (fewer sampled n under the sanitizers, which make every run slower)
ifeq ($(SANITIZE),1)
FAULT_SAMPLES := FAULT_FIRST=4 FAULT_MID=6 FAULT_LAST=4
endif
fault-tests: $(BIN) $(BUILD)/tests/deltamap-faultinj $(BUILD)/tests/fault_write.so
	@DELTAMAP=$(BIN) FAULT_DELTAMAP=$(BUILD)/tests/deltamap-faultinj \
	    FAULT_SHIM=$(BUILD)/tests/fault_write.so $(FAULT_SAMPLES) tests/fault_tests.sh

FUZZ_CC      ?= $(shell command -v clang-14 || command -v clang)
FUZZ_DIR     := build/fuzz-libfuzzer
FUZZ_OPT     := -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined \
                -fno-sanitize-recover=undefined
FUZZ_CFLAGS  := -std=c11 -D_POSIX_C_SOURCE=200809L -D_DEFAULT_SOURCE $(FUZZ_OPT) -Wall -Wextra \
                -Wno-pass-failed -fopenmp -Iinclude
FUZZ_LIB_OBJ := $(patsubst src/%.c,$(FUZZ_DIR)/obj/%.o,$(LIB_SRC)) $(call isa_objs,$(FUZZ_DIR)) \
                $(FUZZ_DIR)/obj/presets.o
FUZZ_BIN     := $(addprefix $(FUZZ_DIR)/fuzz-,$(FUZZ_TARGETS))
FUZZ_SECONDS ?= 600

# (the kernels' rules for each path, once the fuzz build's folders are named)
$(foreach p,$(ISA_PATHS),$(eval $(call isa_rule,$(p))))

fuzz-deps:
	@tools/install-deps.sh --fuzz

fuzz: fuzz-deps
	@$(MAKE) --no-print-directory $(FUZZ_BIN)

$(FUZZ_DIR)/obj/%.o: src/%.c $(ALL_SRC) | $(FUZZ_DIR)/obj
	@mkdir -p $(@D)
	$(FUZZ_CC) $(FUZZ_CFLAGS) -fsanitize=fuzzer-no-link $(PKG_CFLAGS) -c $< -o $@

$(FUZZ_DIR)/obj/presets.o: $(BUILD)/presets.c | $(FUZZ_DIR)/obj
	$(FUZZ_CC) $(FUZZ_CFLAGS) -c $< -o $@

$(FUZZ_DIR)/libdeltamap.a: $(FUZZ_LIB_OBJ)
	rm -f $@
	$(AR) rcs $@ $^

$(FUZZ_DIR)/fuzz-%: tests/fuzz/fuzz_%.c $(FUZZ_SRC) $(FUZZ_HDR) $(FUZZ_DIR)/libdeltamap.a
	$(FUZZ_CC) $(FUZZ_CFLAGS) -fsanitize=fuzzer $(PKG_CFLAGS) -Isrc/cli -Itests/fuzz $< $(FUZZ_SRC) \
	    -o $@ $(FUZZ_DIR)/libdeltamap.a $(PKG_LIBS) $(SUNDIALS_LIBS) $(LDLIBS)

# Each target for FUZZ_SECONDS, one after another (FUZZ_TARGETS=... to pick);
# new inputs go to build/, findings to build/fuzz-libfuzzer/findings/T/.
fuzz-run: fuzz
	@tools/fuzz-run.sh $(FUZZ_SECONDS) $(FUZZ_TARGETS)

$(BUILD)/fuzz $(FUZZ_DIR)/obj:
	mkdir -p $@

install: $(BIN)
	install -d $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(PREFIX)/share/deltamap/robots
	install -m 755 $(BIN) $(DESTDIR)$(PREFIX)/bin/deltamap
	install -m 644 robots/*.ini $(DESTDIR)$(PREFIX)/share/deltamap/robots/

clean:
	rm -rf build
