# SPDX-License-Identifier: MIT
# tools/embedded.mk - included by the Makefile: the IK core cross-built and
# its self-test (tests/embedded/) for every target of docs/EMBEDDED.md.
#
#   ikt-m0q.elf    Cortex-M0, Q5.26, freestanding (QEMU microbit)
#   ikt-m3q.elf    Cortex-M3, Q5.26, freestanding (QEMU mps2-an385)
#   ikt-m4q.elf    Cortex-M4F, Q5.26, freestanding (QEMU mps2-an386)
#   ikt-m4ff.elf   Cortex-M4F, float, hard-float ABI, newlib's libm (QEMU mps2-an386)
#   ikt-a64{q,d,f} aarch64 Linux, Q5.26 / double / float (qemu-aarch64)
#   ikt-host{q,d,f} this machine, the reference for the hashes
#   min-<cfg>-{none,newton,solve}.elf   the smallest firmware without a solver,
#                  with the paper's Newton, with avatargw's solver (code size);
#                  <cfg>l: the same with link-time optimisation
#
# tests/check-embedded.sh runs them as part of `make test`. A family whose
# tools are missing is not built here; the check then says so and is skipped,
# except in CI (AVATARGW_CI=1), where everything is built and must pass.

EMB = $(BUILD)/embedded
ARM_CC ?= arm-none-eabi-gcc
A64_CC ?= aarch64-linux-gnu-gcc
QEMU_ARM ?= qemu-system-arm
QEMU_A64 ?= qemu-aarch64
A64_SYSROOT ?= /usr/aarch64-linux-gnu
# the benchmark rows the self-test solves: random targets (reset), trajectory frames (warm)
EMB_N_RANDOM ?= 200
EMB_N_TRAJ ?= 1000

have = $(shell command -v $(1) >/dev/null 2>&1 && echo yes)
ifeq ($(AVATARGW_CI),1)
EMB_ARM = yes
EMB_A64 = yes
else
# the float image needs newlib's libm as well
EMB_ARM := $(if $(and $(call have,$(ARM_CC)),$(call have,$(QEMU_ARM))),$(if $(filter /%,$(shell $(ARM_CC) -print-file-name=libm.a 2>/dev/null)),yes))
EMB_A64 := $(if $(and $(call have,$(A64_CC)),$(call have,$(QEMU_A64)),$(wildcard $(A64_SYSROOT)/lib/libc.so*)),yes)
endif

EMB_VEC = $(EMB)/ikt_vectors.inc
EMB_CORE = $(patsubst src/ik/%.c,%,$(CORE_SRC_q))
EMB_INC = -Iinclude -Itests/embedded -I$(EMB)
EMB_CORE_FLAGS = -std=c11 $(WARN) -g -fno-math-errno -ffp-contract=off

# Cortex-M: size-optimised, freestanding, unused functions dropped at link time
CM_FLAGS = $(EMB_CORE_FLAGS) -Os -ffreestanding -ffunction-sections -fdata-sections \
	-fno-tree-loop-distribute-patterns
# each object's frame sizes and calls (.su, .ci): tools/stack-depth.py bounds the stack
CM_STACK = -fstack-usage -fcallgraph-info=su
CM_LD = -nostdlib -Ltests/embedded -Wl,--gc-sections
EMB_FLAGS_m0q = -mcpu=cortex-m0 -mthumb $(CM_FLAGS) $(CM_STACK) -DSC_TYPE=SC_FIXQ -DSC_NO_DOUBLE
EMB_FLAGS_m3q = -mcpu=cortex-m3 -mthumb $(CM_FLAGS) $(CM_STACK) -DSC_TYPE=SC_FIXQ -DSC_NO_DOUBLE
EMB_FLAGS_m4q = -mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard $(CM_FLAGS) $(CM_STACK) -DSC_TYPE=SC_FIXQ -DSC_NO_DOUBLE
EMB_FLAGS_m4ff = -mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard $(CM_FLAGS) $(CM_STACK) -DSC_TYPE=SC_FLOAT
EMB_LD_m0q = $(CM_LD) -T tests/embedded/microbit.ld -lgcc
EMB_LD_m3q = $(CM_LD) -T tests/embedded/mps2.ld -lgcc
EMB_LD_m4q = $(CM_LD) -T tests/embedded/mps2.ld -lgcc
# float: libm's sinf/cosf/atan2f back the core's polynomials beyond |a| = 8
EMB_LD_m4ff = $(CM_LD) -T tests/embedded/mps2.ld -lm -lc -lgcc
# the same with link-time optimisation, for the code size of the smallest firmware
$(foreach c,m0q m3q m4q m4ff,$(eval EMB_FLAGS_$(c)l = $$(filter-out $$(CM_STACK),$$(EMB_FLAGS_$(c))) -flto)$(eval EMB_LD_$(c)l = $$(EMB_LD_$(c)))\
	$(eval EMB_CC_$(c)l = $$(EMB_CC_$(c)))$(eval EMB_NAME_$(c)l = $$(EMB_NAME_$(c))))
EMB_NAME_m0q = cortex-m0 (qemu microbit)
EMB_NAME_m3q = cortex-m3 (qemu mps2-an385)
EMB_NAME_m4q = cortex-m4f (qemu mps2-an386)
EMB_NAME_m4ff = cortex-m4f (qemu mps2-an386)
EMB_CC_m0q = $(ARM_CC)
EMB_CC_m3q = $(ARM_CC)
EMB_CC_m4q = $(ARM_CC)
EMB_CC_m4ff = $(ARM_CC)

# Linux processes: aarch64 under qemu-user, and this machine (with SAN=1 under the sanitizers)
EMB_FLAGS_a64q = $(EMB_CORE_FLAGS) -O2 -DSC_TYPE=SC_FIXQ
EMB_FLAGS_a64d = $(EMB_CORE_FLAGS) -O2 -DSC_TYPE=SC_DOUBLE
EMB_FLAGS_a64f = $(EMB_CORE_FLAGS) -O2 -DSC_TYPE=SC_FLOAT
EMB_FLAGS_hostq = $(EMB_CORE_FLAGS) $(OPT) $(SANFLAGS) -DSC_TYPE=SC_FIXQ
EMB_FLAGS_hostd = $(EMB_CORE_FLAGS) $(OPT) $(SANFLAGS) -DSC_TYPE=SC_DOUBLE
EMB_FLAGS_hostf = $(EMB_CORE_FLAGS) $(OPT) $(SANFLAGS) -DSC_TYPE=SC_FLOAT
EMB_NAME_a64q = aarch64 linux (qemu-aarch64)
EMB_NAME_a64d = $(EMB_NAME_a64q)
EMB_NAME_a64f = $(EMB_NAME_a64q)
EMB_NAME_hostq = $(shell uname -m) linux (native)
EMB_NAME_hostd = $(EMB_NAME_hostq)
EMB_NAME_hostf = $(EMB_NAME_hostq)
EMB_CC_a64q = $(A64_CC)
EMB_CC_a64d = $(A64_CC)
EMB_CC_a64f = $(A64_CC)
EMB_CC_hostq = $(CC)
EMB_CC_hostd = $(CC)
EMB_CC_hostf = $(CC)
EMB_LD_a64q = -lm
EMB_LD_a64d = -lm
EMB_LD_a64f = -lm
EMB_LD_hostq = $(LDFLAGS) -lm
EMB_LD_hostd = $(LDFLAGS) -lm
EMB_LD_hostf = $(LDFLAGS) -lm

EMB_CM = m0q m3q m4q m4ff
EMB_CM_LTO = $(addsuffix l,$(EMB_CM))
EMB_LINUX = a64q a64d a64f
EMB_HOST = hostq hostd hostf

$(EMB_VEC): tools/embedded-vectors.sh $(SHARED)/bench/targets.csv $(SHARED)/bench/trajectory.csv
	@mkdir -p $(dir $@)
	tools/embedded-vectors.sh $(SHARED)/bench/targets.csv $(SHARED)/bench/trajectory.csv \
		$(EMB_N_RANDOM) $(EMB_N_TRAJ) >$@.tmp
	mv $@.tmp $@

# objects of one configuration: the core, the self-test and its platform
define emb_config
$(EMB)/$(1)/%.o: src/ik/%.c tools/embedded.mk
	@mkdir -p $$(dir $$@)
	$$(EMB_CC_$(1)) $$(EMB_FLAGS_$(1)) $$(EMB_INC) -MMD -MP -c $$< -o $$@
$(EMB)/$(1)/%.o: tests/embedded/%.c $(EMB_VEC) tools/embedded.mk
	@mkdir -p $$(dir $$@)
	$$(EMB_CC_$(1)) $$(EMB_FLAGS_$(1)) $$(EMB_INC) -DIKT_PLATFORM='"$$(EMB_NAME_$(1))"' -MMD -MP -c $$< -o $$@
$(addprefix $(EMB)/$(1)/min-,none.o newton.o solve.o): $(EMB)/$(1)/min-%.o: tests/embedded/min.c tools/embedded.mk
	@mkdir -p $$(dir $$@)
	$$(EMB_CC_$(1)) $$(EMB_FLAGS_$(1)) $$(EMB_INC) -DIKT_MIN_$$(shell echo $$* | tr a-z A-Z) -MMD -MP -c $$< -o $$@
endef
$(foreach c,$(EMB_CM) $(EMB_CM_LTO) $(EMB_LINUX) $(EMB_HOST),$(eval $(call emb_config,$(c))))

$(EMB)/ikt-%.elf: $(EMB)/%/ikt.o $(EMB)/%/ikt_mcu.o $(addprefix $(EMB)/%/,$(addsuffix .o,$(EMB_CORE)))
	$(EMB_CC_$*) $(EMB_FLAGS_$*) $^ $(EMB_LD_$*) -Wl,-Map=$(@:.elf=.map) -o $@
$(EMB)/min-%-none.elf: $(EMB)/%/min-none.o $(EMB)/%/ikt_mcu.o
	$(EMB_CC_$*) $(EMB_FLAGS_$*) $^ $(EMB_LD_$*) -o $@
$(EMB)/min-%-newton.elf: $(EMB)/%/min-newton.o $(EMB)/%/ikt_mcu.o $(addprefix $(EMB)/%/,$(addsuffix .o,$(EMB_CORE)))
	$(EMB_CC_$*) $(EMB_FLAGS_$*) $^ $(EMB_LD_$*) -Wl,-Map=$(@:.elf=.map) -o $@
$(EMB)/min-%-solve.elf: $(EMB)/%/min-solve.o $(EMB)/%/ikt_mcu.o $(addprefix $(EMB)/%/,$(addsuffix .o,$(EMB_CORE)))
	$(EMB_CC_$*) $(EMB_FLAGS_$*) $^ $(EMB_LD_$*) -Wl,-Map=$(@:.elf=.map) -o $@
$(EMB)/ikt-%: $(EMB)/%/ikt.o $(EMB)/%/ikt_host.o $(addprefix $(EMB)/%/,$(addsuffix .o,$(EMB_CORE)))
	$(EMB_CC_$*) $(EMB_FLAGS_$*) $^ $(EMB_LD_$*) -o $@

EMB_IMAGES = $(addprefix $(EMB)/ikt-,$(EMB_HOST)) \
	$(if $(EMB_ARM),$(foreach c,$(EMB_CM),$(EMB)/ikt-$(c).elf)) \
	$(if $(EMB_A64),$(addprefix $(EMB)/ikt-,$(EMB_LINUX)))
EMB_MIN = $(foreach c,$(EMB_CM) $(EMB_CM_LTO),$(foreach v,none newton solve,$(EMB)/min-$(c)-$(v).elf))

.PHONY: embedded embedded-report
# every image of the self-test this machine can build
embedded: $(EMB_IMAGES)

# the numbers of docs/EMBEDDED.md: sizes, stack, instructions (QEMU -icount), accuracy against double
embedded-report: $(EMB_IMAGES) $(EMB_MIN) $(BUILD)/avatargw-ikcompare
	@tools/embedded-report.sh $(BUILD) $(SHARED)
