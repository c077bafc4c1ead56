# SPDX-License-Identifier: MIT
# avatargw - plain, non-recursive Makefile.
#
#   make            build everything into $(BUILD)
#   make check      the unit tests only: the cmocka binaries and the checks that need no running
#                   daemon (format, layers, config and man page against the key table); under a minute
#   make test       build and run every test: make check's, the end-to-end tests on the real
#                   daemon, the embedded self-test, the service files (add SAN=1 for ASan + UBSan)
#   make bench      the IK benchmark on ../shared/bench, the cycle's instructions and CPU time,
#                   the daemon's latency and capacity; prints each goal met / not met, never fails
#   make eval       score the avatar against ../shared/mocap (docs/FIDELITY.md)
#   make embedded   cross-build the IK core's self-test (Cortex-M, aarch64); embedded-report: its measurements (docs/MEASUREMENTS.md)
#   make install    install under $(DESTDIR)$(PREFIX)
#   make clean

.DEFAULT_GOAL := all
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
# the IK core, the loop's arithmetic: -O3 unrolls and vectorises its fixed-size loops (about 10 % less
# time per avatar in make bench); no contraction, so the results are the same bits as at -O2
CORE_OPT ?= -O3
endif

WARN = -Wall -Wextra -Werror
CFLAGS ?= $(OPT) -g
ALL_CFLAGS = -std=c11 $(WARN) $(CFLAGS) $(SANFLAGS) -Iinclude -MMD -MP
ALL_CXXFLAGS = -std=c++17 $(WARN) $(CFLAGS) $(SANFLAGS) -Iinclude -MMD -MP
LDFLAGS += $(SANFLAGS)
# The IK core is pure: no errno from libm, no contraction differences between targets.
CORE_CFLAGS = -fno-math-errno -ffp-contract=off $(CORE_OPT)

CMOCKA_LIBS = $(shell pkg-config --libs cmocka 2>/dev/null || echo -lcmocka)

# ---- the IK core, once per scalar type ------------------------------------
CORE_SRC = $(wildcard src/ik/*.c)
CORE_TYPES = d f q
# the fixed-point build (q, int32 Q5.26) is the solver: body calibration is host-side setup work
CORE_SRC_q = $(filter-out src/ik/calib.c,$(CORE_SRC))
CORE_OBJ = $(foreach t,$(CORE_TYPES),$(patsubst src/%.c,$(BUILD)/obj/%.$(t).o,$(or $(CORE_SRC_$(t)),$(CORE_SRC))))
LIBIK = $(BUILD)/libavatargw-ik.a

# The scalar types: an object NAME.T.o is its source built with SC_T. qs is the fixed-point
# build counting its saturations, for test_fixq (suffix _qs: links beside the q build).
SC_d = -DSC_TYPE=SC_DOUBLE
SC_f = -DSC_TYPE=SC_FLOAT
SC_q = -DSC_TYPE=SC_FIXQ
SC_qs = -DSC_TYPE=SC_FIXQ -DSC_FIXQ_STATS -DSC_SUFFIX=_qs
SC_TYPES = d f q qs

# The directories built once per scalar type, and what each adds to the flags: the core
# (src/ik), the tools' and the tests' helpers (tools/lib, tests/lib).
SC_DIRS = src/ik tools/lib tests/lib
SC_FLAGS_src/ik = $(CORE_CFLAGS)
SC_FLAGS_tools/lib = -Itools
SC_FLAGS_tests/lib = -Itests
# $(BUILD)/obj/D/%.T.o from D/%.c (the core's objects go to obj/ik), for every D and T
sc_obj_dir = $(BUILD)/obj/$(patsubst src/%,%,$(1))
define sc_rule
$(call sc_obj_dir,$(2))/%.$(1).o: $(2)/%.c
	@mkdir -p $$(dir $$@)
	$$(CC) $$(ALL_CFLAGS) $$(SC_FLAGS_$(2)) $$(SC_$(1)) -c $$< -o $$@
endef
$(foreach t,$(SC_TYPES),$(foreach d,$(SC_DIRS),$(eval $(call sc_rule,$(t),$(d)))))

$(LIBIK): $(CORE_OBJ)
	@rm -f $@
	$(AR) rcs $@ $^

# ---- the daemon: everything but the core, in data-flow order -------------------
# wire (the protocol, shared with clients), config, trackers (sources and
# drivers), frames (latest samples -> pose frames), publish (outputs), daemon
# (loop, control, systemd). main.c alone makes the program.
INIH_LIBS = $(shell pkg-config --libs inih 2>/dev/null || echo -linih)
ZLIB_LIBS = $(shell pkg-config --libs zlib 2>/dev/null || echo -lz)
# Optional libraries (each from its Debian -dev package): a driver or output
# whose library pkg-config cannot find is left out of the build, and the
# daemon says "not built into this daemon" for its type. make test needs them all.
have = $(shell pkg-config --exists $(1) 2>/dev/null && echo 1 || echo 0)
HAVE_LIBMODBUS := $(call have,libmodbus)
HAVE_LIBLO := $(call have,liblo)
HAVE_LIBWEBSOCKETS := $(call have,libwebsockets)
HAVE_HIDAPI := $(call have,hidapi-hidraw)
HAVE_LIBUSB := $(call have,libusb-1.0)
FEATURES = -DHAVE_LIBMODBUS=$(HAVE_LIBMODBUS) -DHAVE_LIBLO=$(HAVE_LIBLO) -DHAVE_LIBWEBSOCKETS=$(HAVE_LIBWEBSOCKETS) \
	-DHAVE_HIDAPI=$(HAVE_HIDAPI) -DHAVE_LIBUSB=$(HAVE_LIBUSB)
# the sources each optional library takes with it
OPT_SRC_LIBMODBUS = src/trackers/modbus_in.c src/publish/modbus_server.c src/publish/modbus_map.c src/wire/regcodec.c
OPT_SRC_LIBLO = src/publish/osc.c
OPT_SRC_LIBWEBSOCKETS = src/publish/websocket.c
OPT_SRC_HIDAPI = src/trackers/hydra.c
OPT_SRC_LIBUSB = src/trackers/polhemus.c
OPT_LIBS_LIBMODBUS = libmodbus
OPT_LIBS_LIBLO = liblo
OPT_LIBS_LIBWEBSOCKETS = libwebsockets
OPT_LIBS_HIDAPI = hidapi-hidraw
OPT_LIBS_LIBUSB = libusb-1.0
OPTIONAL = LIBMODBUS LIBLO LIBWEBSOCKETS HIDAPI LIBUSB
LEFT_OUT = $(foreach o,$(OPTIONAL),$(if $(filter 0,$(HAVE_$(o))),$(OPT_SRC_$(o))))
DEP_LIBS = $(INIH_LIBS) $(ZLIB_LIBS)
DEP_LIBS += $(foreach o,$(OPTIONAL),$(if $(filter 1,$(HAVE_$(o))),$(shell pkg-config --libs $(OPT_LIBS_$(o)))))
LIBS = $(DEP_LIBS) -lpthread -lm
GW_SRC = $(filter-out src/daemon/main.c $(LEFT_OUT),$(wildcard src/base/*.c src/wire/*.c src/config/*.c src/trackers/*.c \
	src/frames/*.c src/publish/*.c src/record/*.c src/daemon/*.c))
GW_OBJ = $(patsubst src/%.c,$(BUILD)/obj/%.o,$(GW_SRC)) $(BUILD)/obj/gen/builtin.o
include src/sites/sites.mk
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
	$(CC) $(ALL_CFLAGS) $(FEATURES) -D_GNU_SOURCE -Isrc -c $< -o $@

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

# tools/lib/ikx.c: the core of one scalar type behind a double interface, once per type
IKX_OBJ = $(foreach t,$(CORE_TYPES),$(BUILD)/obj/tools/lib/ikx.$(t).o)

# tools/lib/benchfile.c: benchmark rows, joint limits and helpers of the IK tools
BENCHFILE_OBJ = $(BUILD)/obj/tools/lib/benchfile.o
$(BUILD)/obj/tools/avatargw-ikcompare.o $(BUILD)/obj/tools/avatargw-ikbench.o $(BUILD)/obj/tools/avatargw-eval.o: \
	ALL_CFLAGS += -Itools
$(BUILD)/avatargw-ikcompare: $(BUILD)/obj/tools/avatargw-ikcompare.o $(IKX_OBJ) $(BENCHFILE_OBJ) $(LIBGW) $(LIBIK)
	$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)
$(BUILD)/avatargw-ikbench $(BUILD)/avatargw-eval: $(BUILD)/avatargw-%: $(BUILD)/obj/tools/avatargw-%.o $(BENCHFILE_OBJ) \
	$(LIBGW) $(LIBIK)
	$(CC) $(LDFLAGS) -o $@ $^ $(LIBS)

# the cycle's benchmark (make bench; not installed)
BENCH_CYCLE = $(BUILD)/bench-cycle
# (its gateway's CLOCK_MONOTONIC follows the cycles it simulates: tools/bench-cycle.c)
$(BENCH_CYCLE): $(BUILD)/obj/tools/bench-cycle.o $(LIBGW) $(LIBIK)
	$(CC) $(LDFLAGS) -Wl,--wrap=clock_gettime -o $@ $^ $(LIBS)

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
TEST_LIB_OBJ = $(foreach t,$(CORE_TYPES),$(patsubst tests/lib/%.c,$(BUILD)/obj/tests/lib/%.$(t).o,$(TEST_LIB_SRC)))

$(BUILD)/obj/tests/%.o: tests/%.c
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CFLAGS) $(TEST_CFLAGS) -D_GNU_SOURCE -Isrc -Itests -DSHARED_DIR='"$(SHARED)"' -c $< -o $@
$(BUILD)/obj/tests/%.o: tests/%.cpp
	@mkdir -p $(dir $@)
	$(CXX) $(ALL_CXXFLAGS) -Itests -DSHARED_DIR='"$(SHARED)"' -c $< -o $@
$(BUILD)/tests/%: $(BUILD)/obj/tests/%.o $(TEST_LIB_OBJ) $(LIBGW) $(LIBIK)
	@mkdir -p $(dir $@)
	$(CXX) $(LDFLAGS) $(TEST_LDFLAGS) -o $@ $^ $(CMOCKA_LIBS) $(LIBS)

# helper programs of the tests (peers built on the same libraries as the daemon)
TEST_HELPERS = $(BUILD)/tests/osc-recv
$(BUILD)/tests/osc-recv: tests/helpers/osc_recv.c
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CFLAGS) -D_GNU_SOURCE $(LDFLAGS) -o $@ $< $(shell pkg-config --libs liblo)

# the tests that read the benchmark's files read them as the IK tools do (tools/lib/benchfile.c)
$(BUILD)/obj/tests/test_arm.o: TEST_CFLAGS = -Itools
$(BUILD)/tests/test_arm: $(BENCHFILE_OBJ)

# test_alloc counts every allocation made by our code: wrapped at link time
$(BUILD)/tests/test_alloc: TEST_LDFLAGS = -Wl,--wrap=malloc,--wrap=calloc,--wrap=realloc,--wrap=free
$(BUILD)/tests/test_udp: TEST_LDFLAGS = -Wl,--wrap=sendmmsg
# ... and on the renderer outputs' side, also the library calls that must stay off the loop thread
$(BUILD)/tests/test_alloc_renderers: TEST_LDFLAGS = -Wl,--wrap=malloc,--wrap=calloc,--wrap=realloc,--wrap=free \
	-Wl,--wrap=lo_message_new,--wrap=lo_send_message,--wrap=lo_send_bundle \
	-Wl,--wrap=lws_write,--wrap=lws_callback_on_writable_all_protocol

# test_fixq is the fixed-point build's own test (sc_t = Q5.26). It holds the core's
# Q5.26 build against the double one through tools/lib/ikx.c, and links a counting
# build of the fixed core (suffix _qs, SC_FIXQ_STATS: how many results saturated)
# and the tests' clip reader (tests/fake/clip.c: the avatar on motion capture).
QS_OBJ = $(patsubst src/%.c,$(BUILD)/obj/%.qs.o,$(CORE_SRC_q)) $(BUILD)/obj/tools/lib/ikx.qs.o
$(BUILD)/obj/tests/test_fixq.o: TEST_CFLAGS = $(SC_q) -Itools
$(BUILD)/tests/test_fixq: $(BUILD)/obj/tests/test_fixq.o $(QS_OBJ) $(IKX_OBJ) $(BUILD)/obj/tests/fake/clip.o $(BENCHFILE_OBJ) \
	$(TEST_LIB_OBJ) $(LIBGW) $(LIBIK)
	@mkdir -p $(dir $@)
	$(CXX) $(LDFLAGS) -o $@ $^ $(CMOCKA_LIBS) $(LIBS)

# The hardware drivers' tests: simulated devices (tests/fake) take the place of
# every hidapi and libusb function the drivers call, and count the loop
# thread's allocations; the steps both tests take with their device are
# tests/fake/devtest.c. The fake objects go before the libraries: they call
# into the gateway themselves (the linker takes from an archive only what is
# wanted by what came before it).
FAKE_OBJ = $(patsubst tests/%.c,$(BUILD)/obj/tests/%.o,$(wildcard tests/fake/*.c))
FAKE_WRAP = hid_init hid_exit hid_enumerate hid_free_enumeration hid_open_path hid_close hid_read_timeout \
	hid_send_feature_report hid_get_feature_report hid_error \
	libusb_init libusb_exit libusb_has_capability libusb_hotplug_register_callback \
	libusb_hotplug_deregister_callback libusb_handle_events_timeout_completed libusb_get_device_list \
	libusb_free_device_list libusb_get_device_descriptor libusb_get_bus_number libusb_get_device_address \
	libusb_get_port_numbers libusb_get_active_config_descriptor libusb_free_config_descriptor libusb_open \
	libusb_close libusb_set_auto_detach_kernel_driver libusb_set_configuration libusb_claim_interface \
	libusb_release_interface libusb_clear_halt libusb_bulk_transfer \
	malloc calloc realloc free
FAKE_TESTS = $(BUILD)/tests/test_hydra $(BUILD)/tests/test_polhemus
$(FAKE_TESTS): $(BUILD)/tests/%: $(BUILD)/obj/tests/%.o $(FAKE_OBJ) $(TEST_LIB_OBJ) $(LIBGW) $(LIBIK)
	@mkdir -p $(dir $@)
	$(CXX) $(LDFLAGS) $(TEST_LDFLAGS) -o $@ $^ $(CMOCKA_LIBS) $(LIBS)
$(FAKE_TESTS): TEST_LDFLAGS = $(foreach f,$(FAKE_WRAP),-Wl,--wrap=$(f))

# the checks make check runs beside TEST_BIN (they run no daemon, quickly), the end-to-end
# tests and the other checks of make test
CHECK_QUICK = tests/check-format.sh tests/check-layers.sh tests/check-config-doc.sh tools/check-man.sh
E2E_TESTS = $(wildcard tests/e2e/test_*.py)
CHECK_SCRIPTS = $(wildcard tests/check-*.sh) tests/service/verify-unit.sh

# ---- fragments ----------------------------------------------------------------
# Parts of the build kept beside what they build, one include each, here: after the
# variables above (which they may use and add to: TEST_BIN, CHECK_QUICK, CHECK_SCRIPTS,
# E2E_TESTS, EXTRA_ALL) and before the top-level targets (which take those lists).

# the core cross-built for microcontrollers and aarch64, and its self-test (docs/EMBEDDED.md)
include tools/embedded.mk
# the fuzz harnesses: make fuzz, and their corpus run in make check and make test (docs/FUZZING.md)
include tests/fuzz/fuzz.mk

# ---- top-level targets --------------------------------------------------------
.SECONDARY:
.PHONY: all check test check-core bench install clean run
all: $(LIBIK) $(LIBGW) $(DAEMON) $(TOOLS) $(EXAMPLES) $(BENCH_CYCLE) $(EXTRA_ALL)

# The core may reference nothing from libc but memcpy/memset and libm's own functions.
CORE_ALLOWED = memcpy memset sin cos sincos atan2 sqrt sinf cosf sincosf atan2f sqrtf
check-core: $(LIBIK)
	@nm --defined-only $(LIBIK) | awk 'NF == 3 {print $$3}' | sort -u >$(BUILD)/core-defined.txt
	@bad=$$(nm -u $(LIBIK) | awk '/ U /{print $$2}' | sed 's/@.*//' | sort -u | comm -23 - $(BUILD)/core-defined.txt | \
		grep -v -x -E '$(subst $() $(),|,$(CORE_ALLOWED))|__asan.*|__ubsan.*|_GLOBAL_OFFSET_TABLE_|__stack_chk_fail' || true); \
	if [ -n "$$bad" ]; then echo "check-core: the IK core references: $$bad"; exit 1; fi; \
	echo "check-core: the IK core references nothing outside itself but: $$(nm -u $(LIBIK) | awk '/ U /{print $$2}' | sort -u | comm -23 - $(BUILD)/core-defined.txt | grep -v -E '^__(asan|ubsan)' | tr '\n' ' ')"

# make check: the unit tests and the checks that read the tree and the daemon's key table
# but run no daemon; make test: those, the end-to-end tests (the real daemon on loopback,
# with the tools and the C++ example client as its peers: all of `all`), the embedded
# self-test (tests/check-embedded.sh: the cross images) and the remaining check scripts
check: $(TEST_BIN) $(DAEMON) check-core
	@BUILD=$(BUILD) tests/run.sh $(TEST_BIN) $(CHECK_QUICK)

test: all $(TEST_BIN) $(TEST_HELPERS) check-core $(EMB_IMAGES)
	@BUILD=$(BUILD) tests/run.sh $(TEST_BIN) $(E2E_TESTS) $(CHECK_QUICK) $(filter-out $(CHECK_QUICK),$(CHECK_SCRIPTS))

# reports and never fails on a goal: each is printed met / not met (docs/MEASUREMENTS.md)
bench: $(BUILD)/avatargw-ikbench $(DAEMON) $(BUILD)/avatargw-dump $(BUILD)/avatargw-ctl $(BENCH_CYCLE)
	@tools/bench.sh $(BUILD) $(SHARED)
	@tools/bench-cycle.sh $(BUILD)
	@tools/bench-daemon.sh $(BUILD)
	@tools/bench-cave.sh $(BUILD)

# the avatar against the motion capture of $(SHARED)/mocap: writes docs/FIDELITY.md and docs/fidelity/*.png
# (minutes, not part of make test; Debian's python3 has matplotlib)
PYTHON ?= $(shell test -x /usr/bin/python3 && echo /usr/bin/python3 || echo python3)
.PHONY: eval
eval: $(BUILD)/avatargw-eval $(BUILD)/avatargw-calib
	$(PYTHON) tools/eval.py --build $(BUILD) --mocap $(SHARED)/mocap/csv

# the embedded demo in the foreground, with a view of the avatar in the terminal
run: all
	@tools/run-demo.sh $(BUILD)

# ---- install / uninstall ------------------------------------------------------
# The daemon goes to sbin (a system service, started by systemd, not by users),
# the tools to bin. The systemd, sysusers and udev files go under $(PREFIX)/lib
# (systemd and udev also read /usr/local/lib/...); SYSCONFDIR is /etc whatever
# PREFIX is, because that is where the daemon looks. An existing
# $(SYSCONFDIR)/avatargw/avatargw.conf is never overwritten: the shipped
# version is always at $(DATADIR)/avatargw/avatargw.conf for comparison.
# See docs/SERVICE.md for what to run after installing.
BINDIR ?= $(PREFIX)/bin
SBINDIR ?= $(PREFIX)/sbin
LIBDIR ?= $(PREFIX)/lib
INCLUDEDIR ?= $(PREFIX)/include
DATADIR ?= $(PREFIX)/share
MANDIR ?= $(DATADIR)/man
SYSCONFDIR ?= /etc
SYSTEMDUNITDIR ?= $(PREFIX)/lib/systemd/system
SYSUSERSDIR ?= $(PREFIX)/lib/sysusers.d
UDEVRULESDIR ?= $(PREFIX)/lib/udev/rules.d
INSTALL_CONF = config/avatargw.conf
INSTALL_CLIPS = $(wildcard config/clips/*)
INSTALL_WWW = $(wildcard www/*)
INSTALL_MAN8 = docs/man/avatargw.8
INSTALL_MAN5 = docs/man/avatargw.conf.5

install: all
	install -d $(DESTDIR)$(BINDIR) $(DESTDIR)$(SBINDIR) $(DESTDIR)$(LIBDIR) $(DESTDIR)$(INCLUDEDIR)/avatargw/ik
	install -d $(DESTDIR)$(DATADIR)/avatargw/clips $(DESTDIR)$(DATADIR)/avatargw/www
	install -d $(DESTDIR)$(MANDIR)/man8 $(DESTDIR)$(MANDIR)/man5
	install -d $(DESTDIR)$(SYSTEMDUNITDIR) $(DESTDIR)$(SYSUSERSDIR) $(DESTDIR)$(UDEVRULESDIR)
	install -d -m 0755 $(DESTDIR)$(SYSCONFDIR)/avatargw $(DESTDIR)$(SYSCONFDIR)/avatargw/conf.d
	install -m 0755 $(DAEMON) $(DESTDIR)$(SBINDIR)/
	install -m 0755 $(TOOLS) $(DESTDIR)$(BINDIR)/
	install -m 0644 $(LIBIK) $(DESTDIR)$(LIBDIR)/
	install -m 0644 include/ik/*.h $(DESTDIR)$(INCLUDEDIR)/avatargw/ik/
	install -m 0644 config/limits-human.txt config/demo.conf $(INSTALL_CONF) $(DESTDIR)$(DATADIR)/avatargw/
	install -m 0644 $(INSTALL_CLIPS) $(DESTDIR)$(DATADIR)/avatargw/clips/
	install -m 0644 $(INSTALL_WWW) $(DESTDIR)$(DATADIR)/avatargw/www/
	install -m 0644 $(INSTALL_MAN8) $(DESTDIR)$(MANDIR)/man8/
	install -m 0644 $(INSTALL_MAN5) $(DESTDIR)$(MANDIR)/man5/
	sed 's|@sbindir@|$(SBINDIR)|g' systemd/avatargw.service >$(DESTDIR)$(SYSTEMDUNITDIR)/avatargw.service
	chmod 0644 $(DESTDIR)$(SYSTEMDUNITDIR)/avatargw.service
	install -m 0644 systemd/avatargw.sysusers $(DESTDIR)$(SYSUSERSDIR)/avatargw.conf
	install -m 0644 systemd/60-avatargw.rules $(DESTDIR)$(UDEVRULESDIR)/
	@if [ -e $(DESTDIR)$(SYSCONFDIR)/avatargw/avatargw.conf ]; then \
		echo "install: keeping $(DESTDIR)$(SYSCONFDIR)/avatargw/avatargw.conf (the shipped one: $(DATADIR)/avatargw/avatargw.conf)"; \
	else \
		echo "install -m 0644 $(INSTALL_CONF) $(DESTDIR)$(SYSCONFDIR)/avatargw/avatargw.conf"; \
		install -m 0644 $(INSTALL_CONF) $(DESTDIR)$(SYSCONFDIR)/avatargw/avatargw.conf; \
	fi

# Removes what install put, but never anything under $(SYSCONFDIR)/avatargw:
# that configuration may be the administrator's own.
.PHONY: uninstall
uninstall:
	rm -f $(DESTDIR)$(SBINDIR)/avatargw
	rm -f $(addprefix $(DESTDIR)$(BINDIR)/,$(notdir $(TOOLS)))
	rm -f $(DESTDIR)$(LIBDIR)/$(notdir $(LIBIK))
	rm -f $(addprefix $(DESTDIR)$(INCLUDEDIR)/avatargw/ik/,$(notdir $(wildcard include/ik/*.h)))
	rmdir $(DESTDIR)$(INCLUDEDIR)/avatargw/ik $(DESTDIR)$(INCLUDEDIR)/avatargw 2>/dev/null || true
	rm -f $(addprefix $(DESTDIR)$(DATADIR)/avatargw/,limits-human.txt demo.conf $(notdir $(INSTALL_CONF)))
	rm -f $(addprefix $(DESTDIR)$(DATADIR)/avatargw/clips/,$(notdir $(INSTALL_CLIPS)))
	rm -f $(addprefix $(DESTDIR)$(DATADIR)/avatargw/www/,$(notdir $(INSTALL_WWW)))
	rmdir $(DESTDIR)$(DATADIR)/avatargw/clips $(DESTDIR)$(DATADIR)/avatargw/www $(DESTDIR)$(DATADIR)/avatargw 2>/dev/null || true
	rm -f $(DESTDIR)$(MANDIR)/man8/$(notdir $(INSTALL_MAN8)) $(DESTDIR)$(MANDIR)/man5/$(notdir $(INSTALL_MAN5))
	rm -f $(DESTDIR)$(SYSTEMDUNITDIR)/avatargw.service
	rm -f $(DESTDIR)$(SYSUSERSDIR)/avatargw.conf
	rm -f $(DESTDIR)$(UDEVRULESDIR)/60-avatargw.rules
	@echo "uninstall: left $(DESTDIR)$(SYSCONFDIR)/avatargw, the avatargw user and /var/lib/avatargw in place"

clean:
	rm -rf build build-san

-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)
