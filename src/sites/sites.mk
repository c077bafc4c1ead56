# SPDX-License-Identifier: MIT
# sites.mk - telecollaboration between sites over Cyclone DDS (src/sites,
# docs/SITES.md), included by the Makefile after GW_OBJ. With Cyclone DDS
# (Debian cyclonedds-dev, cyclonedds-tools for idlc) the IDL's types are
# generated into $(BUILD)/gen/sites; without it the daemon is built with
# site_none.c and refuses a [site] section ("not built in").
SITES_DDS := $(shell pkg-config --exists CycloneDDS && command -v idlc >/dev/null && echo yes)
IDLC ?= idlc

ifeq ($(SITES_DDS),yes)
SITES_GEN = $(BUILD)/gen/sites
# the DDS Security plugins of Debian's libddsc0debian
SITES_PLUGINS := $(shell pkg-config --variable=libdir CycloneDDS)/libddsc0debian
GW_OBJ += $(BUILD)/obj/sites/site.o $(BUILD)/obj/gen/sites/avatargw.o $(BUILD)/obj/gen/sites/ros2.o
LIBS += $(shell pkg-config --libs CycloneDDS)

# one rule per IDL file (a pattern rule: idlc writes the .c and the .h at once)
$(SITES_GEN)/%.c $(SITES_GEN)/%.h: src/sites/%.idl
	@mkdir -p $(SITES_GEN)
	$(IDLC) -o $(SITES_GEN) $<

# the generated code is idlc's: compiled with our flags, its warnings not made errors
$(BUILD)/obj/gen/sites/%.o: $(SITES_GEN)/%.c $(SITES_GEN)/%.h
	@mkdir -p $(dir $@)
	$(CC) $(ALL_CFLAGS) -Wno-error $(shell pkg-config --cflags CycloneDDS) -c $< -o $@

$(BUILD)/obj/sites/site.o: $(SITES_GEN)/avatargw.h $(SITES_GEN)/ros2.h
$(BUILD)/obj/sites/site.o: ALL_CFLAGS += -I$(SITES_GEN) $(shell pkg-config --cflags CycloneDDS) \
	-DSITES_PLUGINS='"$(SITES_PLUGINS)"'

# make bench: the sites' added delay, bandwidth and load (tools/bench-sites.py, docs/SITES.md)
.PHONY: bench-sites
bench-sites: $(BUILD)/avatargw $(BUILD)/avatargw-ctl
	@python3 tools/bench-sites.py $(BUILD)
bench: bench-sites

# the tests' independent peer (tests/helpers/fastdds_peer.cpp): eProsima Fast DDS (libfastrtps-dev) with
# the types fastddsgen (a Java program) generates from the same IDL files; built without the sanitizers
# even under SAN=1 (it is someone else's DDS: ASan reports inside Fast DDS 2.9's own teardown)
FASTDDSGEN ?= fastddsgen
SITES_FASTDDS := $(shell command -v $(FASTDDSGEN) >/dev/null && \
	test -r /usr/include/fastdds/dds/domain/DomainParticipantFactory.hpp && echo yes)
ifeq ($(SITES_FASTDDS),yes)
FASTDDS_GEN = $(BUILD)/gen/fastdds
FASTDDS_SRC = $(foreach f,avatargw ros2,$(FASTDDS_GEN)/$(f).cxx $(FASTDDS_GEN)/$(f)PubSubTypes.cxx)

$(FASTDDS_SRC) &: src/sites/avatargw.idl src/sites/ros2.idl
	@mkdir -p $(FASTDDS_GEN)
	$(FASTDDSGEN) -replace -d $(FASTDDS_GEN) $^ >$(FASTDDS_GEN)/fastddsgen.log

$(BUILD)/tests/fastdds-peer: tests/helpers/fastdds_peer.cpp $(FASTDDS_SRC)
	@mkdir -p $(dir $@)
	$(CXX) -std=c++17 $(CFLAGS) -I$(FASTDDS_GEN) -o $@ $< $(FASTDDS_SRC) -lfastrtps -lfastcdr

test: $(BUILD)/tests/fastdds-peer
endif
else
GW_OBJ += $(BUILD)/obj/sites/site_none.o
endif
