# SPDX-License-Identifier: MIT
# Numeric modes: float (default, single precision) and fixed (Q16.16).
# Included by the Makefile after mk/compile.mk. Defines NUMERIC, the mode of
# the targets that build one (make lib, sim, test-unit, ...), NUM_MODES, and
# per mode, for every build that compiles the firmware:
#   NUM_CFLAGS_<mode>  flags of every compile in that mode
#   NUM_SRCS_<mode>    extra C sources compiled into every build in that mode
#   NUM_DEPS_<mode>    a file that must exist before any of them is compiled
#
# Fixed mode uses libfixmath (div; mul is its fix16_smul, inline in num_fixed.h)
# built from its Debian source package (tools/setup/sources.lock) with one
# configuration, LIBFIXMATH_CONFIG, for the host and for the cross builds
# alike, so that they compute the same numbers
# (firmware/num/num_fixed.h says why each macro is set or not).
#
#   make numerics   docs/numerics.md: the error of every fixed-point primitive
#                   against libm in double precision (tools/numerics/numerics.c)

NUM_MODES := float fixed
NUMERIC ?= float
ifeq ($(filter $(NUMERIC),$(NUM_MODES)),)
$(error NUMERIC must be float or fixed, not '$(NUMERIC)')
endif

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

# The sources appear when the source package is fetched (NUM_DEPS's rule).
$(LIBFIXMATH_SRCS): | $(LIBFIXMATH_DIR)/.sha256
	@test -f $@ || { echo "error: $@ missing after fetching libfixmath" >&2; exit 1; }

# ------------------------------------------------------------------ numerics
# The tool is built in fixed mode whatever NUMERIC is (a build of
# mk/compile.mk: numerics); the document is remade when the tool or the
# primitives change.
NUMERICS_DIR := build/numerics
BUILD_CC_numerics := $(CC)
BUILD_CFLAGS_numerics := $(CSTD) $(OPT) $(FW_INC) $(NUM_CFLAGS_fixed)
BUILD_DIR_numerics := $(NUMERICS_DIR)/obj
BUILD_SRCS_numerics := tools/numerics/numerics.c firmware/num/num_fixed.c $(LIBFIXMATH_SRCS)
BUILD_DEPS_numerics := $(NUM_DEPS_fixed)
BUILD_ORDER_numerics := $(STAMP)/apt-sim
$(eval $(call BUILD,numerics))

$(NUMERICS_DIR)/numerics: $(BUILD_OBJS_numerics)
	$(CC) $^ -lm -o $@

docs/numerics.md: $(NUMERICS_DIR)/numerics
	$< > $@.tmp
	@mv $@.tmp $@

.PHONY: numerics
numerics: docs/numerics.md  ## errors of the fixed-point primitives against libm: docs/numerics.md
