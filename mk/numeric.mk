# SPDX-License-Identifier: MIT
# Numeric mode: float (default, single precision) or fixed (Q16.16).
# Defines, for the Makefile and for mk/cross.mk, mk/firmware.mk, mk/bench.mk,
# mk/numerics.mk, mk/quality.mk:
#   NUM_CFLAGS  flags of every firmware, SIL and test compile in this mode
#   NUM_SRCS    extra C sources compiled into every build in this mode
#   NUM_DEPS    a file that must exist before any of them is compiled
# and the same per mode, whatever NUMERIC is, as NUM_CFLAGS_<mode>,
# NUM_SRCS_<mode>, NUM_DEPS_<mode> (the cross builds and the benchmark build
# both modes at once).
#
# Fixed mode uses libfixmath (mul, div) built from its Debian source package
# (tools/setup/sources.lock) with one configuration, LIBFIXMATH_CONFIG, for the
# host and for the cross builds alike, so that they compute the same numbers
# (firmware/num/num_fixed.h says why each macro is set or not).

LIBFIXMATH_DIR := deps/libfixmath
LIBFIXMATH_CONFIG := -DFIXMATH_NO_CACHE
# fix16.c holds mul and div (the firmware's); fix16_sqrt.c and fix16_trig.c
# are linked for tools/numerics and tools/bench, which measure libfixmath's
# sqrt, sin, cos and atan2 against ours. A static link drops what is unused.
LIBFIXMATH_SRCS := $(addprefix $(LIBFIXMATH_DIR)/,fix16.c fix16_sqrt.c fix16_trig.c)
# libfixmath is not clean under -Wconversion (47 warnings: implicit sign and
# width conversions that are deliberate there); it is clean under every other
# warning of WARN, which stay errors. Our headers do not include its header.
# Every build compiles its sources with these (mk/compile.mk).
LIBFIXMATH_WARN := $(filter-out -Wconversion,$(WARN))

NUM_CFLAGS_float :=
NUM_SRCS_float :=
NUM_DEPS_float :=
NUM_CFLAGS_fixed := -DNUM_FIXED -I$(LIBFIXMATH_DIR) $(LIBFIXMATH_CONFIG)
NUM_SRCS_fixed := $(LIBFIXMATH_SRCS)
NUM_DEPS_fixed := $(LIBFIXMATH_DIR)/.sha256

NUM_CFLAGS := $(NUM_CFLAGS_$(NUMERIC))
NUM_SRCS := $(NUM_SRCS_$(NUMERIC))
NUM_DEPS := $(NUM_DEPS_$(NUMERIC))

# The sources appear when the source package is fetched (NUM_DEPS's rule).
$(LIBFIXMATH_SRCS): | $(LIBFIXMATH_DIR)/.sha256
	@test -f $@ || { echo "error: $@ missing after fetching libfixmath" >&2; exit 1; }
