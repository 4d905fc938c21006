# ctlab: a step-by-step software volume ray caster. Run `make help` for the targets.
#
# Quick start on a fresh Debian/Ubuntu machine:
#   make demo    # install missing packages, build, render every step on the phantom into out/
#   make test    # every test

# --- Build settings ------------------------------------------------------------------------
CXX      ?= g++
# SAN=1 (below) compiles at -O1, as ASan's own documentation advises: measured here, an
# instrumented object costs 30-50% less compiler CPU than at -O2 (tools/check.cpp 46 -> 34 s).
ifeq ($(SAN),1)
OPT      ?= -O1
endif
OPT      ?= -O2
# The tests' own code (assertions and analytic answers; the renders they check run in the
# steps and common/, at OPT) compiles at -O0 with line tables only (-g1: a failure's backtrace
# still names file and line): a fresh clone's `make test` compiles all of tests/ after `make
# demo`, and that took 152 s of compiler CPU at -O1 -g against 70 s at -O0 -g1 (measured
# 2026-11-27 on this 2-core VM; test_volume.cpp alone 12.0 -> 3.8 s). The doctest binary's
# whole run cost no more CPU for it (138 s at -O0 -g1, 156 s at -O1 -g, back to back on a
# busy machine).
TEST_OPT   ?= -O0
TEST_DEBUG ?= -g1
CXXFLAGS += -std=c++17 $(OPT) -g -Wall -Wextra -pthread
# WERROR=1 (CI): every warning stops the build.
ifeq ($(WERROR),1)
CXXFLAGS += -Werror
endif
# stb is a system header: its own warnings are not ours.
CPPFLAGS += -I. -Icommon -isystem /usr/include/stb -MMD -MP
SDL_CFLAGS := $(shell pkg-config --cflags sdl2 2>/dev/null)
SDL_LIBS   := $(shell pkg-config --libs sdl2 2>/dev/null)
CPPFLAGS += $(SDL_CFLAGS)
LDLIBS   += -pthread
# Dear ImGui (libimgui-dev: a static library) for the window's control panel: only the window
# code includes it, and only the window module links it (no OpenGL: the panel draws with
# SDL_Renderer, common/panel_draw.cpp).
IMGUI_LIBS := -limgui -l:libstb.a
# zlib: the checker verifies a PNG's compressed data (CRCs, Adler-32, its inflated size).
# --as-needed: a program maps only the libraries its own code calls (a step needs no zlib:
# the compressed volume files are the format module's).
LDLIBS   += -lz -ldl
LDFLAGS  += -Wl,--as-needed
# The volume formats' libraries (common/format_*.cpp): nifticlib, teem (NRRD), GDCM, zlib.
# Only the format modules (common/module.h) link them; the steps open one when a file needs
# it. DICOM's GDCM is a module of its own (its dictionaries are built when it is loaded).
CPPFLAGS += -I/usr/include/gdcm-3.0 -I/usr/include/nifti
DICOM_LIBS  := -lgdcmMSFF -lgdcmDSED -lgdcmCommon
FORMAT_LIBS := -lniftiio -lznz -lteem $(DICOM_LIBS) -lz
# A module holds only its own code: what it uses of common/ (Volume, Image, the presets' state)
# is the program's own, exported by the program (--export-dynamic, every member of libctlab.a
# linked), so that a module and its program share one copy of everything. A function the
# module defines itself it calls itself (-Bsymbolic-functions): the window module's
# show_preview is the window, where the program's is the stub that opens the module.
MODULE_LDFLAGS := -shared -Wl,-Bsymbolic-functions
PROGRAM_LIB = -Wl,--export-dynamic -Wl,--whole-archive $(LIBCTLAB) -Wl,--no-whole-archive
# The builds inside demo, test and check-student use every core, unless make was given -j.
JOBS     ?= $(shell nproc 2>/dev/null || echo 1)
PARALLEL  = $(if $(filter -j%,$(MAKEFLAGS)),,-j$(JOBS))

# `make fuzz` builds with FUZZ=1: clang, libFuzzer instrumentation, ASan and UBSan, into
# build-fuzz/ unless BUILD is given (`make fuzz BUILD=/tmp/fz`).
FUZZ_BUILD := $(if $(filter command environment,$(origin BUILD)),$(BUILD),build-fuzz)
ifeq ($(FUZZ),1)
BUILD    ?= build-fuzz
CXX      := clang++
CXXFLAGS += -fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer \
            -fno-sanitize-recover=all
LDFLAGS  += -fsanitize=fuzzer,address,undefined
endif

# `make test SAN=1`: AddressSanitizer + UndefinedBehaviorSanitizer, in a build folder of its own.
ifeq ($(SAN),1)
BUILD    ?= build-san
CXXFLAGS += -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all
# GCC 12 with the sanitizers warns falsely inside <regex> (tools/grade.cpp): maybe-uninitialized.
CXXFLAGS += -Wno-maybe-uninitialized
LDFLAGS  += -fsanitize=address,undefined
# Stricter than the defaults, for every test run (the tests add to these, never replace them).
# No test needs a single allocation over 1 GiB: one would be a loader trusting a size field.
export ASAN_OPTIONS ?= check_initialization_order=1:strict_init_order=1:$\
                      detect_stack_use_after_return=1:max_allocation_size_mb=1024
export UBSAN_OPTIONS ?= print_stacktrace=1
export LSAN_OPTIONS ?= suppressions=$(CURDIR)/tests/fuzz/lsan.supp
else
BUILD    ?= build
endif

# stb_image (compiled into image_read.o) calls memcpy(NULL, p, 0) for a PNG whose first IDAT
# chunk is empty: harmless, but UBSan's nonnull check stops there. Found by `make fuzz`.
ifneq ($(SAN)$(FUZZ),)
$(BUILD)/tools/image_read.o: CXXFLAGS += -fno-sanitize=nonnull-attribute
endif

$(BUILD)/tests/%.o: OPT := $(TEST_OPT)
$(BUILD)/tests/%.o: CXXFLAGS += $(TEST_DEBUG)
# STEP_OPT='-O1 -g0': more flags for the steps alone (the last -O and -g win), for the tests'
# throw-away builds of steps (tests/mutants.sh's mistakes, the student kit's stubs). Not in
# the flags stamp: it never rebuilds, nor marks out of date, the rest of the build folder.
ifneq ($(STEP_OPT),)
$(BUILD)/steps/%.o: CXXFLAGS += $(STEP_OPT)
endif
# STEP_LDFLAGS='-fuse-ld=gold': likewise for the steps' links alone, outside the flags stamp
# (those throw-away builds link ~70 steps: measured 0.05 s of CPU a link with gold, 0.14 with
# the default ld.bfd).

# The window code alone sees ImGui's headers (see LDLIBS above).
$(addprefix $(BUILD)/common/,window.o panel.o panel_draw.o): CPPFLAGS += -isystem /usr/include/imgui

STEP_SOURCES   := $(sort $(wildcard steps/[0-9][0-9]_*.cpp))
STEP_NAMES     := $(basename $(notdir $(STEP_SOURCES)))
STEP_BINARIES  := $(addprefix $(BUILD)/,$(STEP_NAMES))
# The format readers are not in libctlab.a: they make the format module (and are linked
# straight into the tests and fuzz harnesses, which call them by name).
FORMAT_SOURCES := $(wildcard common/format_*.cpp) common/inflated_stream.cpp  # zlib: theirs
FORMAT_OBJECTS := $(patsubst %.cpp,$(BUILD)/%.o,$(FORMAT_SOURCES))
# Likewise the window (SDL2): the window module; the steps hold window_module.cpp's side.
WINDOW_SOURCES := common/window.cpp common/panel.cpp common/panel_draw.cpp common/window_entry.cpp
WINDOW_OBJECTS := $(patsubst %.cpp,$(BUILD)/%.o,$(WINDOW_SOURCES))
COMMON_SOURCES := $(filter-out $(FORMAT_SOURCES) $(WINDOW_SOURCES),$(wildcard common/*.cpp))
COMMON_OBJECTS := $(patsubst %.cpp,$(BUILD)/%.o,$(COMMON_SOURCES))
DICOM_OBJECTS  := $(BUILD)/common/format_dicom.o $(BUILD)/common/format_dicom_entry.o
MODULES        := $(BUILD)/ctlab_formats.so $(BUILD)/ctlab_dicom.so $(BUILD)/ctlab_window.so
# tools/run_step.cpp, process.cpp and sandbox.cpp are no tools: they start the programs the
# tests and tools run; compare, image_read and output_folder are the checker's and grader's
# picture code, class_cache a class run's shared builds and runs (libctlab_tools: never linked
# into a step).
TOOL_LIB_SOURCES := tools/run_step.cpp tools/process.cpp tools/sandbox.cpp tools/compare.cpp \
                    tools/image_read.cpp tools/output_folder.cpp tools/class_cache.cpp
TOOL_SOURCES   := $(filter-out $(TOOL_LIB_SOURCES),$(wildcard tools/*.cpp))
TOOL_BINARIES  := $(patsubst tools/%.cpp,$(BUILD)/%,$(TOOL_SOURCES))
# The doctest files tests/test_*.cpp compile as four translation units (TEST_UNIT_1..4, the
# rules below); main.cpp, harness.cpp and the fuzz targets (crash replays) one by one.
TEST_FILES     := $(sort $(wildcard tests/test_*.cpp))
TEST_SOURCES   := $(filter-out $(TEST_FILES),$(wildcard tests/*.cpp)) tests/fuzz/targets.cpp
# The longest first (make -j starts them in this order: make test's suites take the slots
# left over).
TEST_OBJECTS   := $(addprefix $(BUILD)/tests/unit_,2.o 3.o 1.o 4.o) \
                  $(patsubst %.cpp,$(BUILD)/%.o,$(TEST_SOURCES))
LIBCTLAB       := $(BUILD)/libctlab.a
LIBTOOLS       := $(BUILD)/libctlab_tools.a

.PHONY: all help deps demo test run diff clean $(STEP_NAMES)
.PHONY: reference student check-student handouts  # the instructor and student kit, below
.PHONY: carry  # in a student tree: your functions forward into later steps
.PHONY: carry-lab  # in the lab: a fixed function forward into the later steps
.PHONY: check check-steps san  # grading this tree's programs, and one step with the sanitizers
.PHONY: class-bench  # a generated class graded and checked: the README's class timing
.PHONY: fuzz fuzz-build
.PHONY: bench study peers  # measuring: speed, and error against run time
.PHONY: gain  # part 3: each trick's CPU time per render against the step before it
.PHONY: screenshots  # the README's pictures of the window's control panel
.DEFAULT_GOAL := all

# make bench's peers (tools/peer_volpack.c, tools/peer_vtk.py): VolPack's program is built
# only where libvolpack1-dev is installed (`make bench PEERS=1` installs the peers).
VOLPACK_HEADER := $(wildcard /usr/include/volpack.h)
PEER_BINARIES  := $(if $(VOLPACK_HEADER),$(BUILD)/peer_volpack)

# Build every step and tool, and the modules they open (common/module.h).
all: $(STEP_BINARIES) $(TOOL_BINARIES) $(MODULES) $(PEER_BINARIES)

help:
	@echo "make            build every step into $(BUILD)/NN_name, and the tools"
	@echo "make demo       install missing packages, build (the tests too), render every step on"
	@echo "                the phantom"
	@echo "make test       build and run every test (SAN=1: with ASan and UBSan); TEST_JOBS=N"
	@echo "                suites at once, TEST_NICE=0 all at one priority (see the Makefile)"
	@echo "make NN_name    build one step, e.g. make 03_depth_shading"
	@echo "make run STEP=NN [ARGS='--view front']   build and run step NN"
	@echo "make diff STEP=NN   what step NN adds to step NN-1"
	@echo "make carry [STEP=NN]   student tree: copy your lesson functions into the later steps"
	@echo "                that use them unchanged (only where they are still stubs)"
	@echo "make carry-lab FUNCTION=name FROM=NN   the lab: copy step NN's function into the"
	@echo "                later steps that take it unchanged (up to one that changes it)"
	@echo "make deps       install the Debian packages ctlab needs (as root)"
	@echo "make fuzz [FUZZ_SECONDS=N]   build the libFuzzer harnesses (clang) into build-fuzz/"
	@echo "                (or BUILD=DIR) and run each for N seconds (default 60)"
	@echo "make clean      remove build/, build-san/, build-fuzz/ and out/"
	@echo "make reference [VOLUME=CThead REFERENCE=DIR]   render data/reference/manifest.txt's"
	@echo "                images: the phantom into data/reference/, or VOLUME into REFERENCE"
	@echo "                (a raw volume of another size: DIMS=NX,NY,NZ [ENDIAN= SPACING= ARGS=])"
	@echo "make student [FORCE=1]   generate student/: the lab with every lesson function a stub"
	@echo "make check [STEP=NN]   grade this tree's steps (the lab or a student tree): run every"
	@echo "                manifest variant, compare pictures and counters; a progress table"
	@echo "make san STEP=NN [ARGS='...']   build step NN with ASan and UBSan into build-san/ and"
	@echo "                run it (on the phantom): a crash then names its line"
	@echo "make check-student   make check inside student/ (generated first if missing)"
	@echo "make class-bench [N=200 CLASS_JOBS=2]   N generated student trees graded in the"
	@echo "                sandbox (build/grade --class) and checked against their mistakes:"
	@echo "                wall and CPU time per tree (minutes: run it on an idle machine)"
	@echo "make handouts   refresh the code listings in handouts/*.md from the steps' markers"
	@echo "make screenshots   the README's pictures of the window's control panel (xvfb-run)"
	@echo "make bench      time every step and view, 1 and 2 threads, cold and warm (the step"
	@echo "                binaries with --repeat): out/bench.md, and the handouts' speed tables"
	@echo "                (run it on an idle machine)"
	@echo "make study      error against run time of the methods (depth, step size, early"
	@echo "                termination, float/double): out/study/ and the handouts' tables"
	@echo "make bench QUICK=1, make study QUICK=1   a quick run that checks they work (CI)"
	@echo "make bench PEERS=1   install the peers first (VolPack, VTK, xvfb): the peer table"
	@echo "make gain       part 3: CPU time per render of each part-3 step on the bench's four"
	@echo "                cases (1 thread): out/part3_gain.md, and the handouts' gain blocks"

# Install missing Debian packages (as root: apt-get; otherwise prints the one sudo command).
deps:
	@sh tools/install-deps.sh

# Render every step and every view on the phantom into out/, headless. The doctest binary
# (build/ctlab_tests: tests/ compiled and linked) is built with the programs, so that the
# README's second command, make test, starts every suite at once: built inside make test, it
# was the compile and link that the student suite and every doctest file waited for.
demo: deps
	@$(MAKE) --no-print-directory $(PARALLEL) all $(BUILD)/ctlab_tests
	@for step in $(STEP_NAMES); do \
	    $(BUILD)/$$step --volume phantom --view all --no-window --out out || exit 1; \
	done
	@echo "Rendered $(words $(STEP_NAMES)) steps into out/. Open a preview window with:"
	@echo "    $(BUILD)/$(lastword $(STEP_NAMES)) --volume phantom --view front"

# Every test, as suites side by side on every core: each doctest file (tests/test_*.cpp, its
# test cases in $(BUILD)/ctlab_tests) and each script tests/NAME_test.sh is one suite, its
# output in $(BUILD)/test-logs/NAME.log, printed whole when it ends (tests/run_suite.sh). The
# last line adds them all up: "test: N passed, M failed" (tests/test_summary.sh).
# The programs are built first (after `make demo`, which builds the test binary too: nothing
# to do); then every suite is a goal of one make -j, needing only what it runs: a script suite
# the programs, a doctest file the test binary too (and the student kit, which copies it). So
# without make demo first (CI) the scripts start while tests/ compiles. The slowest suites
# start first, so that the last one to finish is a short one (make -j takes the goals in
# order): by their CPU time in a whole make test on an idle machine
# (build/test-logs/NAME.cpu), check and student (~80 and ~60 s) first. The suites
# that spend most of their time waiting for a time limit in the sandbox (WAITING_SUITES:
# class and sandbox, ~40 s of wall time each for 3-5 s of CPU) run beside the job slots,
# started first, so that no core idles while they wait (build/test-logs/NAME.time: when each
# suite started and ended, seconds since the epoch).
# A long doctest file runs as shards side by side (FILE.KofN, tests/shard_cases.sh): no
# single suite of it is the critical path.
# SKIP_SUITES=NAMES leaves suites out, and the summary names them (CI: the sanitizer run);
# a sharded file's name leaves out all its shards.
SHARDED     := test_extremes.1of4 test_extremes.2of4 test_extremes.3of4 test_extremes.4of4
WAITING_SUITES := class sandbox
SLOW_SUITES := $(WAITING_SUITES) check student test_formats grade test_handouts cli panel \
               printed_commands test_steps $(SHARDED) test_ray_plot hostile_files window \
               threshold_mistakes test_free_camera test_compositing bad_input peers \
               test_shadows test_threads test_golden test_isosurface test_jitter test_part3
SCRIPT_SUITES := $(patsubst tests/%_test.sh,%,$(wildcard tests/*_test.sh))
ALL_SUITES  := $(SLOW_SUITES) $(filter-out $(SLOW_SUITES) $(basename $(SHARDED)),\
               $(SCRIPT_SUITES) $(basename $(notdir $(wildcard tests/test_*.cpp))))
SKIPPED     := $(filter $(SKIP_SUITES) $(addsuffix .%,$(SKIP_SUITES)),$(ALL_SUITES))
TEST_SUITES := $(filter-out $(SKIPPED),$(ALL_SUITES))
# The suites that run build/ctlab_tests: the doctest files and their shards, and student
# (its kit takes the lab's test binary rather than building its own).
BINARY_SUITES := $(filter-out $(SCRIPT_SUITES),$(ALL_SUITES)) student
# What the suites run: every program, but under SAN=1 (a build of its own, every object
# instrumented) not the ones no suite of this run starts: bench and study (run by make bench
# and make study, in the release build), and make_student, find_answers and handout_listings
# when the student suite is left out.
SAN_UNUSED    := bench study $(if $(filter student,$(SKIPPED)),make_student find_answers \
                 handout_listings)
TEST_PROGRAMS := $(if $(filter 1,$(SAN)),$(filter-out $(addprefix $(BUILD)/,$(SAN_UNUSED)),\
                 $(STEP_BINARIES) $(TOOL_BINARIES) $(MODULES) $(PEER_BINARIES)),all)
# Job slots and priorities. check and student use about half a core each for most of their
# run (an idle run: check 81 s of CPU in 126 s, student 56 s in 112: serial phases, waits),
# so with one slot a core the cores idled while they ran (~1.2 of 2 busy). Each of them
# (SERIAL_SUITES, when in this run) adds a job slot: TEST_JOBS = JOBS + 2. Those two are the
# critical path (student starts once tests/ is compiled), and some suites need a whole core
# at the time they run (FULL_CORE_SUITES: real windows on a virtual display, signals sent to
# running steps, the peers' timings); they and the compiler run at normal priority, the other
# suites at nice TEST_NICE: they take the cores that the first leave idle, and no more, so
# that the slot more oversubscribes none of them. TEST_NICE=0: all at one priority.
# TEST_JOBS is the suites' own make's, whatever -j the outer make was given: `make -j2 test`
# (CI) passed its jobserver of 2 down before, and ignored JOBS=3.
SERIAL_SUITES    := check student
# test_process: a program spinning to its 1 s CPU limit within a 20 s wall-clock limit; at
# nice 10 on a machine at load ~17 it got less than 1 s of CPU in 20 s (one run in three).
FULL_CORE_SUITES := $(SERIAL_SUITES) panel window bad_input peers test_process
TEST_JOBS ?= $(shell expr $(JOBS) + $(words $(filter $(SERIAL_SUITES),$(TEST_SUITES))))
TEST_NICE ?= 10
SUITES_MAKE = MAKEFLAGS='$(subst ','\'',$(filter-out -j% --jobserver-auth=%,$(MAKEFLAGS)))' \
              $(MAKE) --no-print-directory -k SUITE_NICE=$(TEST_NICE)
# Two makes side by side: the critical path (check, then tests/ compiled, linked, student and
# the doctest files) in TEST_JOBS slots, and the other scripts in JOBS slots of their own. In
# one make, a script suite took the slot that the test binary's link waited for: make -j
# starts the next goal's job in the first slot that frees, and while the last unit compiled
# that was a script suite's (measured at load ~17: all objects compiled 251 s in, the link
# waited until check ended at 431 s).
CRITICAL_SUITES := $(filter $(SERIAL_SUITES) $(BINARY_SUITES),$(TEST_SUITES))
OTHER_SUITES    := $(filter-out $(WAITING_SUITES) $(CRITICAL_SUITES),$(TEST_SUITES))
test: deps
	@$(MAKE) --no-print-directory $(PARALLEL) $(TEST_PROGRAMS)
	@rm -rf $(BUILD)/test-logs
	@for name in $(filter $(WAITING_SUITES),$(TEST_SUITES)); do \
	    sh tests/run_suite.sh $(BUILD) $$name & \
	 done; \
	 $(if $(OTHER_SUITES),$(SUITES_MAKE) -j$(JOBS) $(addprefix test-suite-,$(OTHER_SUITES)) &) \
	 $(if $(CRITICAL_SUITES),$(SUITES_MAKE) -j$(TEST_JOBS) \
	     $(addprefix test-suite-,$(CRITICAL_SUITES))); \
	 wait
	@$(if $(SKIPPED),echo "test: SKIPPED (SKIP_SUITES): $(SKIPPED)")
	@sh tests/test_summary.sh $(BUILD) $(TEST_SUITES)

# One suite: `make test-suite-cli`, `make test-suite-test_extremes.2of4`, with what it needs
# (at normal priority: SUITE_NICE is make test's).
RUN_SUITE = $(if $(filter-out 0,$(SUITE_NICE)),$(if $(filter-out $(FULL_CORE_SUITES),$*),\
                nice -n $(SUITE_NICE) ))sh tests/run_suite.sh $(BUILD) $*
.PHONY: $(addprefix test-suite-,$(ALL_SUITES))
$(addprefix test-suite-,$(ALL_SUITES)): test-suite-%: $(TEST_PROGRAMS)
	@$(RUN_SUITE)
$(addprefix test-suite-,$(BINARY_SUITES)): $(BUILD)/ctlab_tests
# Any other shard of a doctest file (test_extremes.3of8), with the test binary.
test-suite-%: $(TEST_PROGRAMS) $(BUILD)/ctlab_tests
	@$(RUN_SUITE)

# One step by name: `make 03_depth_shading`.
$(STEP_NAMES): %: $(BUILD)/%

# STEP is the step's number: 3 and 03 both mean steps/03_*.cpp. A bad or missing STEP gets
# one line naming the problem and exit status 2, as in `make diff`.
STEP_NUMBER = $(shell case '$(STEP)' in ('' | *[!0-9]*) ;; (*) printf '%02d' "$$(expr '$(STEP)' + 0)";; esac)
STEP_TARGET = $(notdir $(basename $(firstword $(wildcard steps/$(STEP_NUMBER)_*.cpp))))
run:
	@if [ -z "$(STEP)" ]; then echo "make run: say which step, e.g. make run STEP=3 (steps: $(STEP_NAMES))"; exit 2; fi
	@if [ -z "$(STEP_TARGET)" ]; then echo "make run: no step '$(STEP)' (steps: $(STEP_NAMES))"; exit 2; fi
	@$(MAKE) --no-print-directory $(BUILD)/$(STEP_TARGET)
	$(BUILD)/$(STEP_TARGET) $(ARGS)

# What step NN teaches: its diff against the step its header's "// Builds on:  NN_name" names
# (part 2's steps branch: 12 may build on 10), else against step NN-1. In a student tree, of the steps as they
# were handed out (.ctlab/pristine/, written by make student), not of the student's own code.
DIFF_STEPS := $(if $(wildcard .ctlab-student),$(if $(wildcard .ctlab/pristine/steps),.ctlab/pristine/steps,steps),steps)
diff:
	@if [ -z "$(STEP_NUMBER)" ]; then echo "make diff: say which step by number, e.g. make diff STEP=3 (got '$(STEP)')"; exit 2; fi
	@new=$$(ls $(DIFF_STEPS)/$(STEP_NUMBER)_*.cpp 2>/dev/null); \
	 base=$$(sed -n 's|^// Builds on: *\([0-9][0-9]_[a-z0-9_]*\).*|\1|p' $$new /dev/null | head -n 1); \
	 previous=$$(printf '%02d' $$(expr $(STEP_NUMBER) - 1)); \
	 if [ -n "$$base" ]; then old=$$(ls $(DIFF_STEPS)/$$base.cpp 2>/dev/null); \
	 else old=$$(ls $(DIFF_STEPS)/$${previous}_*.cpp 2>/dev/null); fi; \
	 if [ -z "$$new" ] || [ -z "$$old" ]; then echo "make diff: no step $(STEP) or no step before it"; exit 2; fi; \
	 diff -u "$$old" "$$new" || true

clean:
	rm -rf build build-san build-fuzz out

# --- Measuring: speed and accuracy -----------------------------------------------------------
# Every step and view timed with 1 and 2 threads, each step binary run with --repeat: the cold
# first render and the warm median (tools/bench.cpp): out/bench.md; then step 11 --unlit,
# and every step's top view on the phantom at 512^3 (time per visited sample against the
# 256x256 view's, peak memory against the volume's size). Each target: met or missed.
# Timing needs an idle machine: check `uptime`.
# With the peers installed (PEERS=1 installs them: VolPack, VTK), a table of them against ctlab's
# fastest step per case, interleaved in the same run (tools/bench.cpp, peers_section).
# QUICK=1 (CI): a small volume and one render per case, to check the tool still works.
# A full run then copies its figures into the handouts' <!-- measured: bench:... --> blocks
# (tools/measured.cpp), so a handout's speed table is always the last `make bench`.
bench: $(if $(filter 1,$(PEERS)),peers) $(BUILD)/bench $(BUILD)/measured $(STEP_BINARIES) \
       $(PEER_BINARIES)
ifeq ($(PEERS),1)
	@$(MAKE) --no-print-directory $(BUILD)/peer_volpack
endif
ifeq ($(QUICK),1)
	$(BUILD)/bench --quick --out out/bench_quick.md
else
	$(BUILD)/bench --out out/bench.md
	$(BUILD)/measured out/bench.md
endif

# N generated student trees graded in one command and checked against make_class's record of
# their mistakes (tools/class_bench.sh): the README's class timing table.
class-bench: $(BUILD)/grade $(BUILD)/check $(STEP_BINARIES) $(MODULES)
	@sh tools/class_bench.sh $(BUILD) $(or $(N),200) $(or $(CLASS_JOBS),2)

# The peers for make bench (PEERS=1): VolPack, VTK, a virtual X display for VTK (as root).
peers:
	@sh tools/install-deps.sh peers

# Error against run time of each method and parameter, and the stiff numerical cases
# (tools/study.cpp): out/study/error_vs_time.csv, .png and .md, out/study/numerics.md.
# QUICK=1 (CI): one render per case, a small phantom (out/study_quick/). A full run then
# copies its tables into the handouts' <!-- measured: study:... --> blocks and its plot to
# handouts/error_vs_time.png.
study: $(BUILD)/study $(BUILD)/measured $(STEP_BINARIES)
ifeq ($(QUICK),1)
	$(BUILD)/study --quick --out out/study_quick
else
	$(BUILD)/study --out out/study
	$(BUILD)/measured out/study/error_vs_time.md
	$(BUILD)/measured out/study/numerics.md
	cp out/study/error_vs_time.png handouts/error_vs_time.png
endif

# Part 3's gains: every part-3 step on the bench's four cases (the peer table's flags), CPU
# time per render on one thread (build/bench --gain; CPU time from the child's rusage, so a
# shared machine spoils it less than wall time): out/part3_gain.md, copied into the handouts'
# <!-- measured: gain:NN_name --> blocks.
PART3_BINARIES := $(filter $(BUILD)/3% $(BUILD)/4%,$(STEP_BINARIES))  # part 3: steps 30 on
gain: $(BUILD)/bench $(BUILD)/measured $(PART3_BINARIES)
	$(BUILD)/bench --gain --out out/part3_gain.md
	$(BUILD)/measured out/part3_gain.md

# --- Instructor and student kit: references, student skeletons, handout listings ----------
# Render every step and view, and the variants data/reference/manifest.txt lists, into
# data/reference/ on the phantom; or, given VOLUME=path/to/CThead, into REFERENCE=folder.
# A raw volume of another size: DIMS=NX,NY,NZ [ENDIAN=big] [SPACING=SX,SY,SZ]; ARGS= adds flags
# to every run. REFERENCE/volume.txt records the volume, its flags, the commit and the date.
# The values reach the script through the environment, never pasted into the shell's text:
# VOLUME='a`touch x`.raw' or a '"' in ARGS stays a plain string.
reference: export CTLAB_VOLUME := $(value VOLUME)
reference: export CTLAB_REFERENCE := $(value REFERENCE)
reference: export CTLAB_DIMS := $(value DIMS)
reference: export CTLAB_ENDIAN := $(value ENDIAN)
reference: export CTLAB_SPACING := $(value SPACING)
reference: export CTLAB_ARGS := $(value ARGS)
reference: $(STEP_BINARIES)
	@DIMS="$$CTLAB_DIMS" ENDIAN="$$CTLAB_ENDIAN" SPACING="$$CTLAB_SPACING" ARGS="$$CTLAB_ARGS" \
	    sh tools/make_reference.sh '$(BUILD)' "$$CTLAB_VOLUME" "$$CTLAB_REFERENCE"

# Generate student/: the lab with each lesson function's body a TODO stub (tools/make_student).
# Refuses to overwrite files changed since the last generation unless FORCE=1.
student: $(BUILD)/make_student
	$(BUILD)/make_student --to student $(if $(filter 1,$(FORCE)),--force)

# Grade this tree's programs (tools/check.cpp), in the lab or in a student tree: build every
# step (or STEP=NN; one that does not compile is graded "not built"), run each with every run
# of data/reference/manifest.txt on the phantom into out/check/, compare every picture and the
# work counters with the reference run's, and print a progress table with what to look at.
CHECK_STEPS = $(if $(STEP),$(filter $(STEP) $(STEP)_%,$(STEP_NAMES)),$(STEP_NAMES))
check: $(BUILD)/check
	@$(MAKE) --no-print-directory -k $(PARALLEL) check-steps || \
	    echo "make check: a step does not compile (the compiler's errors are above)"
	@$(BUILD)/check --bin $(BUILD) $(if $(STEP),--step $(STEP))
check-steps: $(addprefix $(BUILD)/,$(CHECK_STEPS))
	@:

# One step built with AddressSanitizer and UndefinedBehaviorSanitizer, then run: a crash then
# prints the file and line. ARGS are the step's flags (default: every view on the phantom).
SAN_STEP = $(notdir $(basename $(wildcard steps/$(STEP)_*.cpp)))
san:
	@[ -n "$(SAN_STEP)" ] || { echo "make san: give STEP=NN, one of the steps in steps/"; exit 2; }
	@$(MAKE) --no-print-directory $(PARALLEL) SAN=1 build-san/$(SAN_STEP)
	build-san/$(SAN_STEP) --volume phantom --no-window --out out/san $(ARGS)

# make check inside student/ (generated first if missing): the verdict the student sees.
check-student:
	@[ -f student/.ctlab-student ] || $(MAKE) --no-print-directory student
	@$(MAKE) --no-print-directory -C student check

# In a student tree: copy the student's lesson functions forward into the later steps that use
# them unchanged, where those are still the generated stubs (tools/carry.cpp, .ctlab/carry.txt).
carry: export CTLAB_STEP := $(value STEP)
carry: $(BUILD)/carry
	@'$(BUILD)/carry' $(if $(value STEP),--step "$$CTLAB_STEP")

# In the lab: a fix to step FROM's function FUNCTION reaches every later step that takes it
# unchanged (tools/carry.cpp --lab; tests/test_lesson_markers.cpp fails when copies differ).
carry-lab: export CTLAB_FUNCTION := $(value FUNCTION)
carry-lab: export CTLAB_FROM := $(value FROM)
carry-lab: $(BUILD)/carry
	@'$(BUILD)/carry' --lab --function "$$CTLAB_FUNCTION" --from "$$CTLAB_FROM"

# The README's pictures of the window's control panel: steps 07 and 25 on a virtual X display
# (xvfb-run), into handouts/panel_NN_name.png (tools/panel_screenshots.sh).
screenshots: $(BUILD)/07_back_to_front $(BUILD)/25_free_leaping
	sh tools/panel_screenshots.sh $(BUILD) handouts

# Rewrite every <!-- listing: FILE MARKER --> block in handouts/*.md from the code.
handouts: $(BUILD)/handout_listings
	$(BUILD)/handout_listings

# --- Fuzzing: tests/fuzz/fuzz_NAME.cpp; what each harness checks is in tests/fuzz/targets.cpp --
# Each runs FUZZ_SECONDS on build-fuzz/corpus/NAME (kept between runs), seeded from
# tests/fuzz/seeds/NAME and the crash inputs kept in tests/fuzz/regressions/NAME. A crash
# stops the run and leaves its input in build-fuzz/crashes/NAME/: copy it to
# tests/fuzz/regressions/NAME/, where `make test` replays it (tests/test_fuzz_regressions.cpp).
# The harnesses run side by side, one a core (libFuzzer's runs use one thread): with 2 cores
# the nine take about half the wall time they took one after another, each its FUZZ_SECONDS.
FUZZ_HARNESSES := raw cthead tf image nifti nrrd metaimage dicom volume_data
FUZZ_SECONDS   ?= 60
.PHONY: $(addprefix fuzz-run-,$(FUZZ_HARNESSES))
fuzz:
	@sh tools/install-deps.sh fuzz
	@$(MAKE) --no-print-directory $(PARALLEL) FUZZ=1 BUILD=$(FUZZ_BUILD) fuzz-build
	@rm -f $(addprefix $(FUZZ_BUILD)/,$(addsuffix .passed,$(FUZZ_HARNESSES)))
	@$(MAKE) --no-print-directory $(PARALLEL) -k $(addprefix fuzz-run-,$(FUZZ_HARNESSES)) || :
	@passed=$$(ls $(addprefix $(FUZZ_BUILD)/,$(addsuffix .passed,$(FUZZ_HARNESSES))) \
	    2> /dev/null | wc -l); \
	echo "fuzz: $$passed passed, $$(($(words $(FUZZ_HARNESSES)) - passed)) failed"; \
	[ $$passed -eq $(words $(FUZZ_HARNESSES)) ]

# One harness for FUZZ_SECONDS: its log in $(FUZZ_BUILD)/NAME.log, and NAME.passed if no crash.
# (A static pattern rule: make looks for no implicit rule for a .PHONY target.)
$(addprefix fuzz-run-,$(FUZZ_HARNESSES)): fuzz-run-%:
	@mkdir -p $(FUZZ_BUILD)/corpus/$* $(FUZZ_BUILD)/crashes/$*
	@kept=tests/fuzz/regressions/$*; [ -d $$kept ] || kept=; \
	LSAN_OPTIONS=suppressions=$(CURDIR)/tests/fuzz/lsan.supp \
	$(FUZZ_BUILD)/fuzz_$* -max_total_time=$(FUZZ_SECONDS) -close_fd_mask=1 \
	    -print_final_stats=1 -artifact_prefix=$(FUZZ_BUILD)/crashes/$*/ \
	    $(FUZZ_BUILD)/corpus/$* tests/fuzz/seeds/$* $$kept \
	    > $(FUZZ_BUILD)/$*.log 2>&1 || { tail -n 40 $(FUZZ_BUILD)/$*.log; \
	    echo "fuzz: $* crashed; input in $(FUZZ_BUILD)/crashes/$*/"; exit 1; }; \
	echo "fuzz: $*: $$(sed -n 's/^stat::number_of_executed_units: *//p' \
	    $(FUZZ_BUILD)/$*.log) runs in $(FUZZ_SECONDS) s, no crash"; \
	touch $(FUZZ_BUILD)/$*.passed

fuzz-build: $(addprefix $(BUILD)/fuzz_,$(FUZZ_HARNESSES))

# --- Rules ---------------------------------------------------------------------------------
# The compiler and its flags, kept in $(BUILD)/flags.txt: when they change (SAN=1 into the
# same folder, a Makefile that links otherwise), everything is built again rather than mixed.
BUILD_FLAGS := $(CXX) $(CPPFLAGS) $(CXXFLAGS) $(TEST_OPT) $(TEST_DEBUG) | $(LDFLAGS) $(LDLIBS) | $(FORMAT_LIBS) $(SDL_LIBS) \
               $(IMGUI_LIBS) \
               | $(MODULE_LDFLAGS) | $(PROGRAM_LIB)
FLAGS_STAMP := $(BUILD)/flags.txt
# Only a make that builds may rewrite it: a test's `make reference STEP_BINARIES=` or
# `make carry` given other flags must not mark the whole build folder out of date. Nor may
# `make fuzz` nor its harnesses' runs (fuzz-run-NAME), which build only in their FUZZ=1
# sub-make: given BUILD=DIR, their stamp of DIR with g++'s flags made that sub-make compile
# every object again, run after run.
STAMP_GOALS := $(filter-out reference carry carry-lab diff help clean run fuzz fuzz-run-%,\
                            $(or $(MAKECMDGOALS),all))
ifneq ($(STAMP_GOALS),)
ifneq ($(BUILD_FLAGS),$(shell cat $(FLAGS_STAMP) 2>/dev/null))
$(shell mkdir -p $(BUILD) && printf '%s\n' '$(BUILD_FLAGS)' > $(FLAGS_STAMP))
endif
endif
# A goal left out above that builds (`make carry` as the first command in a fresh student kit:
# its tool) finds no stamp: one is written, as it would have been. An existing stamp is kept.
$(FLAGS_STAMP):
	@mkdir -p $(@D) && printf '%s\n' '$(BUILD_FLAGS)' > $@

# Every object is kept, also those make would delete as intermediate (a step's, a tool's): the
# student kit and grade_test reuse the lab's objects, and a deleted one was compiled again there.
.SECONDARY:

$(BUILD)/%.o: %.cpp $(FLAGS_STAMP)
	@mkdir -p $(dir $@)
	$(CXX) $(CPPFLAGS) $(CXXFLAGS) -c $< -o $@

# Every step starts with #include "common/ctlab.h": that header is compiled once per build
# folder ($(STEP_PCH), GCC's precompiled header, found first on the steps' include path), which
# takes ~0.45 s of compiler CPU off each step (measured at -O0; the lab's build, the tests'
# mutants and the student kit's stubs all compile steps). It is made from a one-line source
# that includes the header (GCC warns of "#pragma once in main file" for the header itself),
# with the steps' own flags, STEP_OPT included; GCC ignores a precompiled header made with
# other flags and reads common/ctlab.h instead. Not for clang (make fuzz), which does not
# look for one there.
ifeq ($(findstring clang,$(CXX)),)
STEP_PCH := $(BUILD)/pch/common/ctlab.h.gch
$(STEP_PCH): common/ctlab.h $(FLAGS_STAMP)
	@mkdir -p $(dir $@) $(BUILD)/pch_source
	echo '#include "common/ctlab.h"' > $(BUILD)/pch_source/ctlab.h
	$(CXX) $(CPPFLAGS) $(CXXFLAGS) $(STEP_OPT) -MT $@ -MF $(@:.gch=.d) \
	    -x c++-header $(BUILD)/pch_source/ctlab.h -o $@
$(BUILD)/steps/%.o: CPPFLAGS := -I$(BUILD)/pch $(CPPFLAGS)
$(patsubst %.cpp,$(BUILD)/%.o,$(STEP_SOURCES)): $(STEP_PCH)
endif

# The tests compile without a precompiled header: as four units (below) a precompiled header
# of doctest and the standard headers saved ~1.6 s of compiler CPU a unit, and cost 4 s to
# make, before any unit could start; in `make test` the suites then took the job slots that
# the units waited for (make -j starts the next goal's job while a unit waits for its header).
# The doctest files in four units, by the letter after "test_": a file's unit depends on its
# own name only, so a new test file compiles its unit again and not the others. Unit N is a
# generated source ($(BUILD)/tests/unit_N.cpp, tests/unity_source.sh) that includes its files,
# each in a namespace of its own. One by one, each file parsed the same headers and compiled
# the same templates of doctest and the standard library (std::regex, std::filesystem) again:
# measured at -O0 -g1, the 29 files took 51 s of compiler CPU one by one, 27 s as one unit
# (one run each, load ~12); the four units, each ~1/4 of that work, still compile side by side.
# The generated source is no prerequisite, its files are: the student kit copies the objects
# and not the generated sources, and does not compile them again. __FILE__ names each test file
# as before ("tests/NAME.cpp", not "./tests/NAME.cpp"): doctest's --source-file filters and
# failure messages are unchanged. (tests/test_summary.sh fails a doctest file with no test case
# in the binary: a file renamed into another unit keeps its time, and that unit may not see it
# as new. `make -B build/ctlab_tests` then.)
TEST_UNIT_1 := $(filter tests/test_a% tests/test_b% tests/test_c% tests/test_d% tests/test_e% \
                        tests/test_f%,$(TEST_FILES))
TEST_UNIT_2 := $(filter tests/test_g% tests/test_h% tests/test_i% tests/test_j% tests/test_k% \
                        tests/test_l% tests/test_m% tests/test_n% tests/test_o%,$(TEST_FILES))
TEST_UNIT_3 := $(filter tests/test_p% tests/test_q% tests/test_r%,$(TEST_FILES))
TEST_UNIT_4 := $(filter-out $(TEST_UNIT_1) $(TEST_UNIT_2) $(TEST_UNIT_3),$(TEST_FILES))
$(BUILD)/tests/unit_1.o: $(TEST_UNIT_1)
$(BUILD)/tests/unit_2.o: $(TEST_UNIT_2)
$(BUILD)/tests/unit_3.o: $(TEST_UNIT_3)
$(BUILD)/tests/unit_4.o: $(TEST_UNIT_4)
$(BUILD)/tests/unit_%.o: tests/unity_source.sh $(FLAGS_STAMP)
	@mkdir -p $(dir $@)
	sh tests/unity_source.sh $(TEST_UNIT_$*) > $(@:.o=.cpp)
	$(CXX) $(CPPFLAGS) -fmacro-prefix-map=./= $(CXXFLAGS) -c $(@:.o=.cpp) -o $@
	@sed -i '1s| $(@:.o=.cpp)||' $(@:.o=.d)

# Every file of common/ too: build/check --build refuses a library older than any of them (it
# builds strangers' steps against it), and a header only the steps include (object_order.h)
# rebuilt no object of it, so `make` left the refusal standing. Archiving again is cheap.
$(LIBCTLAB): $(COMMON_OBJECTS) $(wildcard common/*)
	rm -f $@
	$(AR) rcs $@ $(filter %.o,$^)

$(LIBTOOLS): $(patsubst %.cpp,$(BUILD)/%.o,$(TOOL_LIB_SOURCES))
	rm -f $@
	$(AR) rcs $@ $(filter %.o,$^)

MODULE_LINK = $(CXX) $(MODULE_LDFLAGS) $(LDFLAGS) $(filter %.o,$^)
# A module's code is position-independent; no semantic interposition, so that its calls
# inline as they would in a program.
$(FORMAT_OBJECTS) $(WINDOW_OBJECTS): CXXFLAGS += -fPIC -fno-semantic-interposition
$(BUILD)/ctlab_formats.so: $(filter-out $(DICOM_OBJECTS),$(FORMAT_OBJECTS)) $(FLAGS_STAMP)
	$(MODULE_LINK) $(filter-out $(DICOM_LIBS),$(FORMAT_LIBS)) -o $@

$(BUILD)/ctlab_dicom.so: $(DICOM_OBJECTS) $(FLAGS_STAMP)
	$(MODULE_LINK) $(DICOM_LIBS) -o $@

$(BUILD)/ctlab_window.so: $(WINDOW_OBJECTS) $(FLAGS_STAMP)
	$(MODULE_LINK) $(IMGUI_LIBS) $(SDL_LIBS) -o $@

# Steps and tools open the modules beside them: built with them.
$(BUILD)/%: $(BUILD)/steps/%.o $(LIBCTLAB) $(FLAGS_STAMP) | $(MODULES)
	$(CXX) $(LDFLAGS) $(STEP_LDFLAGS) $< $(PROGRAM_LIB) $(LDLIBS) -o $@

$(BUILD)/%: $(BUILD)/tools/%.o $(LIBTOOLS) $(LIBCTLAB) $(FLAGS_STAMP) | $(MODULES)
	$(CXX) $(LDFLAGS) $< $(LIBTOOLS) $(PROGRAM_LIB) $(LDLIBS) -o $@

# VolPack's peer: C, its own small program (libvolpack.a, static).
$(BUILD)/peer_volpack: tools/peer_volpack.c $(FLAGS_STAMP)
	@mkdir -p $(dir $@)
	$(CC) -std=c11 $(OPT) -g -Wall -Wextra $(if $(filter 1,$(WERROR)),-Werror) $< -lvolpack -lm -o $@

# A harness links the loaders and parsers with the objects of common/ and tools/ they call,
# not the whole of libctlab.a and libctlab_tools.a (the linker took these members and no
# others): make fuzz compiles only those with clang and its instrumentation, about a third
# less of its build. A harness that calls more fails to link, naming the function: add the
# object that defines it here.
FUZZ_LIB_OBJECTS := $(addprefix $(BUILD)/common/,args.o error.o file_input.o formats.o image.o \
                        module.o output_files.o phantom.o render.o transfer_function.o volume.o) \
                    $(addprefix $(BUILD)/tools/,compare.o image_read.o)
$(BUILD)/fuzz_%: $(BUILD)/tests/fuzz/fuzz_%.o $(BUILD)/tests/fuzz/targets.o $(FORMAT_OBJECTS) \
                 $(FUZZ_LIB_OBJECTS)
	$(CXX) $(LDFLAGS) $(filter %.o %.a,$^) $(FORMAT_LIBS) $(LDLIBS) -o $@

# The tests run the step binaries (tools/run_step.h): built with them.
# They call the format readers and the panel's editor by name: linked in (not the window).
PANEL_OBJECTS := $(BUILD)/common/panel.o $(BUILD)/common/panel_draw.o
$(BUILD)/ctlab_tests: $(TEST_OBJECTS) $(FORMAT_OBJECTS) $(PANEL_OBJECTS) $(LIBTOOLS) \
                      $(LIBCTLAB) $(FLAGS_STAMP) | $(STEP_BINARIES) $(MODULES)
	$(CXX) $(LDFLAGS) $(TEST_OBJECTS) $(FORMAT_OBJECTS) $(PANEL_OBJECTS) $(LIBTOOLS) \
	    $(PROGRAM_LIB) $(FORMAT_LIBS) $(IMGUI_LIBS) $(SDL_LIBS) $(LDLIBS) -o $@

# The compiler's dependency files, read as makefiles. Make tries to remake every makefile it
# reads before anything else, and with no rule for a .d file it searched every pattern rule
# (the match-anything $(BUILD)/% above, chained) for each of the ~110: about 1 s of CPU per
# make run, measured, before any recipe (`make help` 1.0 s -> 0.04 s). A .d file is written
# by the compiler only: its rule says so, and does nothing.
%.d: ;
-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)
