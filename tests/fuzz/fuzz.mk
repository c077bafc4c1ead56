# SPDX-License-Identifier: MIT
# tests/fuzz: one libFuzzer harness per parser of the daemon (docs/FUZZING.md).
#
#   make fuzz [FUZZ_TIME=60] [FUZZ_ONLY="wire can"]   every harness built with clang and
#                                     -fsanitize=fuzzer,address,undefined, run FUZZ_TIME s each
#   make check, make test             run each harness (built with $(CC), also under SAN=1)
#                                     over its corpus: tests/check-fuzz.sh
#
# The seeds: tests/fuzz/corpus/NAME/ (committed: small hand-made inputs and
# every input a harness once failed on) and $(BUILD)/fuzz/seeds/NAME/, made
# from the test data, config/ and docs/ by tools/fuzz-seeds.sh.

FUZZ_NAMES = $(patsubst tests/fuzz/fuzz_%.c,%,$(wildcard tests/fuzz/fuzz_*.c))

# ---- the regression run: the harnesses with our own driver, the normal compiler and flags ----
FUZZ_REGRESS = $(foreach n,$(FUZZ_NAMES),$(BUILD)/fuzz/fuzz_$(n))
FUZZ_SEEDS_STAMP = $(BUILD)/fuzz/seeds/.stamp

$(FUZZ_REGRESS): $(BUILD)/fuzz/%: $(BUILD)/obj/tests/fuzz/%.o $(BUILD)/obj/tests/fuzz/driver.o $(LIBGW) $(LIBIK)
	@mkdir -p $(dir $@)
	$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)

$(FUZZ_SEEDS_STAMP): tools/fuzz-seeds.sh $(wildcard tests/data/*) $(wildcard config/*.conf) \
	$(wildcard docs/*.md)
	tools/fuzz-seeds.sh $(BUILD) $(BUILD)/fuzz/seeds
	@touch $@

.PHONY: fuzz-regress fuzz-seeds
fuzz-regress: $(FUZZ_REGRESS) $(FUZZ_SEEDS_STAMP)
fuzz-seeds: $(FUZZ_SEEDS_STAMP)
# tests/check-fuzz.sh, seconds, no daemon: one of make check's quick checks (and so of make test's)
CHECK_QUICK += tests/check-fuzz.sh
check test: fuzz-regress

# ---- make fuzz: clang, libFuzzer, ASan + UBSan, in a build directory of its own ----
FUZZ_BUILD ?= build-fuzz
FUZZ_CC ?= $(shell command -v clang-14 || command -v clang)
FUZZ_TIME ?= 60
FUZZ_ONLY ?= $(FUZZ_NAMES)
FUZZ_SAN = -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer
FUZZ_CFLAGS = -std=c11 $(WARN) -O1 -g $(FUZZ_SAN) -fsanitize=fuzzer-no-link -Iinclude -MMD -MP
# the harnesses configure no [site]: the library without DDS (src/sites/site_none.c)
FUZZ_GW_OBJ = $(patsubst src/%.c,$(FUZZ_BUILD)/obj/%.o,$(GW_SRC)) $(FUZZ_BUILD)/obj/gen/builtin.o \
	$(FUZZ_BUILD)/obj/sites/site_none.o
FUZZ_CORE_OBJ = $(foreach t,$(CORE_TYPES),$(patsubst src/%.c,$(FUZZ_BUILD)/obj/%.$(t).o,\
	$(or $(CORE_SRC_$(t)),$(CORE_SRC))))
FUZZ_BIN = $(foreach n,$(FUZZ_NAMES),$(FUZZ_BUILD)/fuzz_$(n))

$(FUZZ_BUILD)/obj/ik/%.d.o: src/ik/%.c
	@mkdir -p $(dir $@)
	$(FUZZ_CC) $(FUZZ_CFLAGS) $(CORE_CFLAGS) $(SC_d) -c $< -o $@
$(FUZZ_BUILD)/obj/ik/%.f.o: src/ik/%.c
	@mkdir -p $(dir $@)
	$(FUZZ_CC) $(FUZZ_CFLAGS) $(CORE_CFLAGS) $(SC_f) -c $< -o $@
$(FUZZ_BUILD)/obj/ik/%.q.o: src/ik/%.c
	@mkdir -p $(dir $@)
	$(FUZZ_CC) $(FUZZ_CFLAGS) $(CORE_CFLAGS) $(SC_q) -c $< -o $@
$(FUZZ_BUILD)/gen/builtin.c: $(BUILTIN_FILES) tools/embed.sh
	@mkdir -p $(dir $@)
	tools/embed.sh $@ $(BUILTIN_FILES)
$(FUZZ_BUILD)/obj/gen/builtin.o: $(FUZZ_BUILD)/gen/builtin.c
	@mkdir -p $(dir $@)
	$(FUZZ_CC) $(FUZZ_CFLAGS) -Isrc -c $< -o $@
$(FUZZ_BUILD)/obj/%.o: src/%.c
	@mkdir -p $(dir $@)
	$(FUZZ_CC) $(FUZZ_CFLAGS) -D_GNU_SOURCE -Isrc -c $< -o $@
$(FUZZ_BUILD)/obj/tests/fuzz/%.o: tests/fuzz/%.c
	@mkdir -p $(dir $@)
	$(FUZZ_CC) $(FUZZ_CFLAGS) -D_GNU_SOURCE -Isrc -Itests -c $< -o $@
$(FUZZ_BUILD)/libavatargw.a: $(FUZZ_GW_OBJ)
	@rm -f $@
	$(AR) rcs $@ $^
$(FUZZ_BUILD)/libavatargw-ik.a: $(FUZZ_CORE_OBJ)
	@rm -f $@
	$(AR) rcs $@ $^
$(FUZZ_BIN): $(FUZZ_BUILD)/%: $(FUZZ_BUILD)/obj/tests/fuzz/%.o $(FUZZ_BUILD)/libavatargw.a $(FUZZ_BUILD)/libavatargw-ik.a
	$(FUZZ_CC) $(FUZZ_SAN) -fsanitize=fuzzer -o $@ $^ $(LIBS)

.PHONY: fuzz fuzz-build
fuzz-build: $(FUZZ_BIN)

# each harness for FUZZ_TIME s from its seeds; what it finds goes to $(FUZZ_BUILD)/corpus/NAME
# (new inputs) and $(FUZZ_BUILD)/crash/NAME/ (a failing input: copy it into tests/fuzz/corpus/NAME/)
fuzz: fuzz-build $(FUZZ_SEEDS_STAMP)
	@FUZZ_TIME=$(FUZZ_TIME) tools/fuzz-run.sh $(FUZZ_BUILD) $(BUILD)/fuzz/seeds $(FUZZ_ONLY)

-include $(shell find $(FUZZ_BUILD) -name '*.d' 2>/dev/null)

# make clean removes the fuzz build too
.PHONY: clean-fuzz
clean: clean-fuzz
clean-fuzz:
	rm -rf $(FUZZ_BUILD)
