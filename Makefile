# SPDX-License-Identifier: MIT
# avatargw - plain, non-recursive Makefile.
#
#   make            build everything into $(BUILD)
#   make test       build and run every test (add SAN=1 for ASan + UBSan)
#   make bench      run the IK benchmark on ../shared/bench
#   make install    install under $(DESTDIR)$(PREFIX)
#   make clean

PREFIX ?= /usr/local
DESTDIR ?=
SHARED ?= ../shared
CC ?= cc
CXX ?= c++

ifeq ($(SAN),1)
BUILD ?= build-san
SANFLAGS = -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer
OPT ?= -O1
else
BUILD ?= build
SANFLAGS =
OPT ?= -O2
endif

WARN = -Wall -Wextra -Werror
CFLAGS ?= $(OPT) -g
ALL_CFLAGS = -std=c11 $(WARN) $(CFLAGS) $(SANFLAGS) -Iinclude -MMD -MP
ALL_CXXFLAGS = -std=c++17 $(WARN) $(CFLAGS) $(SANFLAGS) -Iinclude -MMD -MP
LDFLAGS += $(SANFLAGS)
# The IK core is pure: no errno from libm, no contraction differences between targets.
CORE_CFLAGS = -fno-math-errno -ffp-contract=off

CMOCKA_LIBS = $(shell pkg-config --libs cmocka 2>/dev/null || echo -lcmocka)

# ---- the IK core, once per scalar type ------------------------------------
CORE_SRC = $(wildcard src/ik/*.c)
CORE_TYPES = d f
CORE_OBJ = $(foreach t,$(CORE_TYPES),$(patsubst src/%.c,$(BUILD)/obj/%.$(t).o,$(CORE_SRC)))
LIBIK = $(BUILD)/libavatargw-ik.a

SC_d = -DSC_TYPE=SC_DOUBLE
SC_f = -DSC_TYPE=SC_FLOAT

$(BUILD)/obj/ik/%.d.o: src/ik/%.c
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CFLAGS) $(CORE_CFLAGS) $(SC_d) -c $< -o $@
$(BUILD)/obj/ik/%.f.o: src/ik/%.c
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CFLAGS) $(CORE_CFLAGS) $(SC_f) -c $< -o $@

$(LIBIK): $(CORE_OBJ)
	@rm -f $@
	$(AR) rcs $@ $^

# ---- the daemon: everything but the core, in data-flow order -------------------
# wire (the protocol, shared with clients), config, trackers (sources and
# drivers), frames (latest samples -> pose frames), publish (outputs), daemon
# (loop, control, systemd). main.c alone makes the program.
INIH_LIBS = $(shell pkg-config --libs inih 2>/dev/null || echo -linih)
LIBS = $(INIH_LIBS) -lpthread -lm
GW_SRC = $(filter-out src/daemon/main.c,$(wildcard src/wire/*.c src/config/*.c src/trackers/*.c \
	src/frames/*.c src/publish/*.c src/daemon/*.c))
GW_OBJ = $(patsubst src/%.c,$(BUILD)/obj/%.o,$(GW_SRC)) $(BUILD)/obj/gen/builtin.o
# files compiled into the daemon: the demo configuration and its clip
BUILTIN_FILES = config/demo.conf config/clips/cmu_141_16.csv

$(BUILD)/gen/builtin.c: $(BUILTIN_FILES) tools/embed.sh
	@mkdir -p $(dir $@)
	tools/embed.sh $@ $(BUILTIN_FILES)

$(BUILD)/obj/gen/builtin.o: $(BUILD)/gen/builtin.c
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CFLAGS) -Isrc -c $< -o $@
LIBGW = $(BUILD)/libavatargw.a
DAEMON = $(BUILD)/avatargw

$(BUILD)/obj/%.o: src/%.c
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CFLAGS) -D_GNU_SOURCE -Isrc -c $< -o $@

$(LIBGW): $(GW_OBJ)
	@rm -f $@
	$(AR) rcs $@ $^

$(DAEMON): $(BUILD)/obj/daemon/main.o $(LIBGW) $(LIBIK)
	$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)

# ---- tools ------------------------------------------------------------------
# every tools/avatargw-*.c is one program linked with both libraries;
# every tools/examples/*.cpp an example client
TOOL_SRC = $(wildcard tools/avatargw-*.c)
TOOLS = $(patsubst tools/%.c,$(BUILD)/%,$(TOOL_SRC))
EXAMPLE_SRC = $(wildcard tools/examples/*.cpp)
EXAMPLES = $(patsubst tools/examples/%.cpp,$(BUILD)/examples/%,$(EXAMPLE_SRC))

$(BUILD)/obj/tools/%.o: tools/%.c
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CFLAGS) -D_GNU_SOURCE -Isrc -c $< -o $@

$(BUILD)/avatargw-%: $(BUILD)/obj/tools/avatargw-%.o $(LIBGW) $(LIBIK)
	$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)

$(BUILD)/obj/examples/%.o: tools/examples/%.cpp
	@mkdir -p $(dir $@)
	$(CXX) $(ALL_CXXFLAGS) -c $< -o $@

$(BUILD)/examples/%: $(BUILD)/obj/examples/%.o $(LIBGW)
	@mkdir -p $(dir $@)
	$(CXX) $(LDFLAGS) -o $@ $^ -lm

# ---- tests --------------------------------------------------------------------
TEST_C = $(wildcard tests/test_*.c)
TEST_CXX = $(wildcard tests/test_*.cpp)
TEST_BIN = $(patsubst tests/%.c,$(BUILD)/tests/%,$(TEST_C)) $(patsubst tests/%.cpp,$(BUILD)/tests/%,$(TEST_CXX))
# helpers linked into every test binary (built once per type where named *.tmpl.c)
TEST_LIB_SRC = $(wildcard tests/lib/*.c)
TEST_LIB_OBJ = $(patsubst tests/lib/%.c,$(BUILD)/obj/tests/lib/%.d.o,$(TEST_LIB_SRC)) \
	$(patsubst tests/lib/%.c,$(BUILD)/obj/tests/lib/%.f.o,$(TEST_LIB_SRC))

$(BUILD)/obj/tests/lib/%.d.o: tests/lib/%.c
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CFLAGS) $(SC_d) -Itests -c $< -o $@
$(BUILD)/obj/tests/lib/%.f.o: tests/lib/%.c
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CFLAGS) $(SC_f) -Itests -c $< -o $@
$(BUILD)/obj/tests/%.o: tests/%.c
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CFLAGS) -D_GNU_SOURCE -Isrc -Itests -DSHARED_DIR='"$(SHARED)"' -c $< -o $@
$(BUILD)/obj/tests/%.o: tests/%.cpp
	@mkdir -p $(dir $@)
	$(CXX) $(ALL_CXXFLAGS) -Itests -DSHARED_DIR='"$(SHARED)"' -c $< -o $@
$(BUILD)/tests/%: $(BUILD)/obj/tests/%.o $(TEST_LIB_OBJ) $(LIBGW) $(LIBIK)
	@mkdir -p $(dir $@)
	$(CXX) $(LDFLAGS) -o $@ $^ $(CMOCKA_LIBS) $(LIBS)

# ---- top-level targets --------------------------------------------------------
.SECONDARY:
.PHONY: all test check-core bench install clean run
all: $(LIBIK) $(LIBGW) $(DAEMON) $(TOOLS) $(EXAMPLES)

# The core may reference nothing from libc but memcpy/memset and libm's own functions.
CORE_ALLOWED = memcpy memset sin cos sincos atan2 sqrt sinf cosf sincosf atan2f sqrtf
check-core: $(LIBIK)
	@nm --defined-only $(LIBIK) | awk 'NF == 3 {print $$3}' | sort -u >$(BUILD)/core-defined.txt
	@bad=$$(nm -u $(LIBIK) | awk '/ U /{print $$2}' | sed 's/@.*//' | sort -u | comm -23 - $(BUILD)/core-defined.txt | \
		grep -v -x -E '$(subst $() $(),|,$(CORE_ALLOWED))|__asan.*|__ubsan.*|_GLOBAL_OFFSET_TABLE_|__stack_chk_fail' || true); \
	if [ -n "$$bad" ]; then echo "check-core: the IK core references: $$bad"; exit 1; fi; \
	echo "check-core: the IK core references nothing outside itself but: $$(nm -u $(LIBIK) | awk '/ U /{print $$2}' | sort -u | comm -23 - $(BUILD)/core-defined.txt | grep -v -E '^__(asan|ubsan)' | tr '\n' ' ')"

test: all $(TEST_BIN) check-core
	@tests/run.sh $(TEST_BIN)

bench: $(BUILD)/avatargw-ikbench
	@tools/bench.sh $(BUILD) $(SHARED)

run: bench

install: all
	install -d $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(PREFIX)/lib $(DESTDIR)$(PREFIX)/include/avatargw/ik
	install -d $(DESTDIR)$(PREFIX)/share/avatargw
	install -m 0755 $(TOOLS) $(DESTDIR)$(PREFIX)/bin/
	install -m 0644 $(LIBIK) $(DESTDIR)$(PREFIX)/lib/
	install -m 0644 include/ik/*.h $(DESTDIR)$(PREFIX)/include/avatargw/ik/
	install -m 0644 config/limits-human.txt $(DESTDIR)$(PREFIX)/share/avatargw/

clean:
	rm -rf build build-san

-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)
