# Numeric mode flags: float (default) or fixed (Q16.16, libfixmath).
ifeq ($(NUMERIC),fixed)
NUM_CFLAGS := -DNUM_FIXED
NUM_SRCS :=
NUM_DEPS :=
else
NUM_CFLAGS :=
NUM_SRCS :=
NUM_DEPS :=
endif
