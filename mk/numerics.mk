# SPDX-License-Identifier: MIT
# make numerics: docs/numerics.md, the error of every fixed-point primitive
# against libm in double precision (tools/numerics/numerics.c). The tool is
# built in fixed mode whatever NUMERIC is; the document is remade when the
# tool or the primitives change. Uses from the Makefile: CC, CSTD, OPT, FW_INC,
# STAMP; from mk/numeric.mk: LIBFIXMATH_*, NUM_*_fixed. A build of
# mk/compile.mk (numerics).

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
