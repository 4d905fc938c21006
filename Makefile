# ctlab: a step-by-step software volume ray caster. Run `make help` for the targets.
#
# Quick start on a fresh Debian/Ubuntu machine:
#   make demo    # install missing packages, build, render every step on the phantom into out/
#   make test    # every test

# --- Build settings ------------------------------------------------------------------------
CXX      ?= g++
OPT      ?= -O2
CXXFLAGS += -std=c++17 $(OPT) -g -Wall -Wextra -pthread
# stb is a system header: its own warnings are not ours.
CPPFLAGS += -I. -Icommon -isystem /usr/include/stb -MMD -MP
SDL_CFLAGS := $(shell pkg-config --cflags sdl2 2>/dev/null)
SDL_LIBS   := $(shell pkg-config --libs sdl2 2>/dev/null)
CPPFLAGS += $(SDL_CFLAGS)
LDLIBS   += $(SDL_LIBS) -pthread

# `make test SAN=1`: AddressSanitizer + UndefinedBehaviorSanitizer, in a build folder of its own.
ifeq ($(SAN),1)
BUILD    ?= build-san
CXXFLAGS += -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all
LDFLAGS  += -fsanitize=address,undefined
else
BUILD    ?= build
endif

STEP_SOURCES   := $(sort $(wildcard steps/[0-9][0-9]_*.cpp))
STEP_NAMES     := $(basename $(notdir $(STEP_SOURCES)))
STEP_BINARIES  := $(addprefix $(BUILD)/,$(STEP_NAMES))
COMMON_SOURCES := $(wildcard common/*.cpp)
COMMON_OBJECTS := $(patsubst %.cpp,$(BUILD)/%.o,$(COMMON_SOURCES))
TOOL_SOURCES   := $(wildcard tools/*.cpp)
TOOL_BINARIES  := $(patsubst tools/%.cpp,$(BUILD)/%,$(TOOL_SOURCES))
TEST_SOURCES   := $(wildcard tests/*.cpp)
TEST_OBJECTS   := $(patsubst %.cpp,$(BUILD)/%.o,$(TEST_SOURCES))
LIBCTLAB       := $(BUILD)/libctlab.a

.PHONY: all help deps demo test run diff clean $(STEP_NAMES)
.DEFAULT_GOAL := all

# Build every step and tool.
all: $(STEP_BINARIES) $(TOOL_BINARIES)

help:
	@echo "make            build every step into $(BUILD)/NN_name, and the tools"
	@echo "make demo       install missing packages, build, render every step on the phantom"
	@echo "make test       build and run every test (SAN=1: with ASan and UBSan)"
	@echo "make NN_name    build one step, e.g. make 03_depth_shading"
	@echo "make run STEP=NN [ARGS='--view front']   build and run step NN"
	@echo "make diff STEP=NN   what step NN adds to step NN-1"
	@echo "make deps       install the Debian packages ctlab needs (as root)"
	@echo "make clean      remove build/ and out/"

# Install missing Debian packages (as root: apt-get; otherwise prints the one sudo command).
deps:
	@sh tools/install-deps.sh

# Render every step and every view on the phantom into out/, headless.
demo: deps
	@$(MAKE) --no-print-directory all
	@for step in $(STEP_NAMES); do \
	    $(BUILD)/$$step --volume phantom --view all --no-window --out out || exit 1; \
	done
	@echo "Rendered $(words $(STEP_NAMES)) steps into out/. Open a preview window with:"
	@echo "    $(BUILD)/$(lastword $(STEP_NAMES)) --volume phantom --view front"

# Every test: unit, analytic and golden tests (doctest), then the command-line and window tests.
test: deps
	@$(MAKE) --no-print-directory all $(BUILD)/ctlab_tests
	$(BUILD)/ctlab_tests
	@sh tests/cli_test.sh $(BUILD)
	@sh tests/window_test.sh $(BUILD)

# One step by name: `make 03_depth_shading`.
$(STEP_NAMES): %: $(BUILD)/%

run: $(BUILD)/$(notdir $(basename $(wildcard steps/$(STEP)_*.cpp)))
	$< $(ARGS)

# What step NN teaches: its diff against step NN-1.
diff:
	@previous=$$(printf '%02d' $$(( 10#$(STEP) - 1 ))); \
	 old=$$(ls steps/$${previous}_*.cpp 2>/dev/null); new=$$(ls steps/$(STEP)_*.cpp 2>/dev/null); \
	 if [ -z "$$new" ] || [ -z "$$old" ]; then echo "make diff: no step $(STEP) or no step before it"; exit 2; fi; \
	 diff -u "$$old" "$$new" || true

clean:
	rm -rf build build-san out

# --- Rules ---------------------------------------------------------------------------------
$(BUILD)/%.o: %.cpp
	@mkdir -p $(dir $@)
	$(CXX) $(CPPFLAGS) $(CXXFLAGS) -c $< -o $@

$(LIBCTLAB): $(COMMON_OBJECTS)
	$(AR) rcs $@ $^

$(BUILD)/%: $(BUILD)/steps/%.o $(LIBCTLAB)
	$(CXX) $(LDFLAGS) $^ $(LDLIBS) -o $@

$(BUILD)/%: $(BUILD)/tools/%.o $(LIBCTLAB)
	$(CXX) $(LDFLAGS) $^ $(LDLIBS) -o $@

$(BUILD)/ctlab_tests: $(TEST_OBJECTS) $(LIBCTLAB)
	$(CXX) $(LDFLAGS) $^ $(LDLIBS) -o $@

-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)
