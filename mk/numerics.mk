# make numerics: docs/numerics.md, the error of every fixed-point primitive
# against libm in double precision (tools/numerics/numerics.c). The tool is
# built in fixed mode whatever NUMERIC is; the document is remade when the
# tool or the primitives change. Uses from the Makefile: CC, CSTD, OPT, WARN,
# STAMP; from mk/numeric.mk: LIBFIXMATH_*, NUM_*_fixed.

NUMERICS_DIR := build/numerics
NUMERICS_FIX_OBJS := $(patsubst %.c,$(NUMERICS_DIR)/obj/%.o,$(LIBFIXMATH_SRCS))

$(NUMERICS_DIR)/obj/%.o: %.c $(NUM_DEPS_fixed) | $(STAMP)/apt-sim
	@mkdir -p $(@D)
	$(CC) $(CSTD) $(OPT) $(LIBFIXMATH_WARN) $(NUM_CFLAGS_fixed) -c $< -o $@

$(NUMERICS_DIR)/numerics: tools/numerics/numerics.c firmware/num/num_fixed.c \
    firmware/num/num_fixed.h firmware/num/num.h $(NUMERICS_FIX_OBJS)
	$(CC) $(CSTD) $(OPT) $(WARN) -Ifirmware $(NUM_CFLAGS_fixed) tools/numerics/numerics.c \
	  firmware/num/num_fixed.c $(NUMERICS_FIX_OBJS) -lm -o $@

docs/numerics.md: $(NUMERICS_DIR)/numerics
	$< > $@.tmp
	@mv $@.tmp $@

.PHONY: numerics
numerics: docs/numerics.md  ## errors of the fixed-point primitives against libm: docs/numerics.md
