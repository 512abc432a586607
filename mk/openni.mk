# OpenNI2 private folder and depthpose's own OpenNI2 driver (platform/openni_driver/).
# Debian's OpenNI2 2.2 loads drivers only from <dir of libOpenNI2.so.0>/OpenNI2/Drivers/. The CLI,
# tests and benchmarks find libOpenNI2.so.0 through their rpath $ORIGIN/../openni, so
# $(BUILD)/openni/ is that directory: a symlink to the system library, the system file-playback
# driver (libOniFile) and our feed driver — and nothing that scans USB.
# The native multiarch folder (x86_64-linux-gnu, aarch64-linux-gnu): a path, not a package query,
# so that no make invocation pays for dpkg.
NATIVE_LIBDIR := /usr/lib/$(shell uname -m)-linux-gnu
OPENNI_SYSTEM_LIB := $(NATIVE_LIBDIR)/libOpenNI2.so.0
ONIFILE_SYSTEM_DRIVER := $(NATIVE_LIBDIR)/OpenNI2/Drivers/libOniFile.so.0

OPENNI_DIR        := $(BUILD)/openni
OPENNI_LIB_LINK   := $(OPENNI_DIR)/libOpenNI2.so.0
OPENNI_ONIFILE    := $(OPENNI_DIR)/OpenNI2/Drivers/libOniFile.so.0
OPENNI_FEED       := $(OPENNI_DIR)/OpenNI2/Drivers/libdepthpose_feed.so.0
OPENNI_FEED_SRCS  := $(sort $(wildcard platform/openni_driver/*.cc))
OPENNI_FEED_OBJS  := $(OPENNI_FEED_SRCS:%.cc=$(BUILD)/obj/%.pic.o)
OPENNI_TARGETS    := $(OPENNI_LIB_LINK) $(OPENNI_ONIFILE) $(OPENNI_FEED)

EXTRA_LINK_DEPS += $(OPENNI_TARGETS)
# all/test-unit/bench list $(EXTRA_LINK_DEPS) before this file is read; add the edges here.
all test-unit test-bin bench chain-smoke: $(OPENNI_TARGETS)

$(OPENNI_LIB_LINK):
	@mkdir -p $(@D)
	ln -sfn $(OPENNI_SYSTEM_LIB) $@
$(OPENNI_ONIFILE):
	@mkdir -p $(@D)
	ln -sfn $(ONIFILE_SYSTEM_DRIVER) $@

$(BUILD)/obj/platform/openni_driver/%.pic.o: platform/openni_driver/%.cc
	@mkdir -p $(@D)
	$(CXX) $(TOOLS_CXXFLAGS) -fPIC -fvisibility=hidden $(DEPFLAGS) -c $< -o $@
$(OPENNI_FEED): $(OPENNI_FEED_OBJS)
	@mkdir -p $(@D)
	$(CXX) $(TOOLS_CXXFLAGS) -shared -fPIC -Wl,-soname,libdepthpose_feed.so.0 -o $@ $^ -pthread

-include $(OPENNI_FEED_OBJS:.o=.d)

# Real cameras: `make openni-devices` adds Debian's PrimeSense/Asus drivers (PS1080, PSLink) to
# the private folder; `make openni-devices FREENECT_DRIVER=/path/libFreenectDriver.so` adds the
# Kinect v1 driver built from libfreenect (docs/app.md). Not part of `make`: tests stay hermetic.
OPENNI_SYSTEM_DRIVERS_DIR := $(dir $(ONIFILE_SYSTEM_DRIVER))
.PHONY: openni-devices
openni-devices: $(OPENNI_TARGETS)
	@for d in libPS1080.so.0 libPSLink.so.0; do \
	  if [ -e $(OPENNI_SYSTEM_DRIVERS_DIR)$$d ]; then ln -sfn $(OPENNI_SYSTEM_DRIVERS_DIR)$$d $(OPENNI_DIR)/OpenNI2/Drivers/$$d; \
	  echo "linked $$d"; else echo "missing $(OPENNI_SYSTEM_DRIVERS_DIR)$$d (install libopenni2-0)"; fi; done
	@if [ -n "$(FREENECT_DRIVER)" ]; then \
	  if [ -e "$(FREENECT_DRIVER)" ]; then ln -sfn "$(abspath $(FREENECT_DRIVER))" $(OPENNI_DIR)/OpenNI2/Drivers/libFreenectDriver.so.0; \
	  echo "linked $(FREENECT_DRIVER) as libFreenectDriver.so.0"; else echo "FREENECT_DRIVER=$(FREENECT_DRIVER) does not exist"; exit 1; fi; fi
