# SPDX-License-Identifier: MIT
# How a C source of the project becomes an object, said once for every build
# (host, unit tests, cross, board images, coverage, fuzzing, benchmark,
# numerics), and compile_commands.json written from the same words. Included
# by the Makefile before every build; uses WARN, and mk/numeric.mk's
# LIBFIXMATH_DIR, LIBFIXMATH_WARN when a recipe runs.
#
# A build is a name N with:
#   BUILD_CC_N      the compiler
#   BUILD_CFLAGS_N  its flags but the warnings: standard, optimisation, CPU,
#                   FW_INC, numeric mode
#   BUILD_DIR_N     where its objects go: BUILD_DIR_N/<source path>.o
#   BUILD_SRCS_N    its sources
#   BUILD_DEPS_N    prerequisites of every object (a fetched source tree)
#   BUILD_ORDER_N   order-only prerequisites (installed packages, generated
#                   headers)
# and `$(eval $(call BUILD,N))` defines its pattern rule, BUILD_OBJS_N, the
# dependency files, and its entries of compile_commands.json.
#
# Every source gets WARN, except libfixmath's, which get LIBFIXMATH_WARN
# (mk/numeric.mk says why), then the flags its directory and the file itself
# need in every build that compiles them: SRC_CFLAGS_<dir> and
# SRC_CFLAGS_<file> (the unit tests' Unity and fakes, the benchmark's
# generated header).

# The objects of sources $(2) in build $(1).
build_objs = $(patsubst %.c,$(BUILD_DIR_$(1))/%.o,$(2))
# The flags source $(1) adds to its build's.
src_cflags = $(if $(filter $(LIBFIXMATH_DIR)/%,$(1)),$(LIBFIXMATH_WARN),$(WARN)) \
  $(SRC_CFLAGS_$(patsubst %/,%,$(dir $(1)))) $(SRC_CFLAGS_$(1))
# gcc's flags that clang does not know (it stops on them): a source that needs
# one in its gcc builds (mk/firmware.mk) compiles without it under clang (the
# fuzzing build).
GCC_ONLY_CFLAGS := -fno-tree-loop-distribute-patterns
# The command that compiles source $(2) of build $(1) into object $(3).
build_cmd = $(strip $(BUILD_CC_$(1)) $(BUILD_CFLAGS_$(1)) \
  $(if $(filter clang%,$(notdir $(BUILD_CC_$(1)))),$(filter-out $(GCC_ONLY_CFLAGS), \
    $(call src_cflags,$(2))),$(call src_cflags,$(2))) -MMD -MP -c $(2) -o $(3))

# Build, source and object of every compile, in the order the builds are
# declared.
COMPILES :=

define BUILD
BUILD_OBJS_$(1) := $$(call build_objs,$(1),$$(BUILD_SRCS_$(1)))
$$(BUILD_DIR_$(1))/%.o: %.c $$(BUILD_DEPS_$(1)) | $$(BUILD_ORDER_$(1))
	@mkdir -p $$(@D)
	$$(call build_cmd,$(1),$$<,$$@)
-include $$(BUILD_OBJS_$(1):.o=.d)
.SECONDARY: $$(BUILD_OBJS_$(1))
COMPILES += $$(foreach s,$$(BUILD_SRCS_$(1)),$(1)@$$(s)@$$(call build_objs,$(1),$$(s)))
endef

# ------------------------------------------------------ compile_commands.json
# The exact command of every compile above, for clangd and clang-tidy
# (`clang-tidy -p .`), the host builds first, NUMERIC's first (clangd takes
# a file's first entry). Written from make's own variables rather than by
# recording a build (Debian's bear): recording sees only what one run
# actually compiled, so it would need a forced rebuild of every build, with
# every toolchain and fetched source present, to list them all; here the
# entries come from the words the recipes run, and cannot drift from them.
comma := ,
define nl


endef
json_str = "$(subst ",\",$(subst \,\\,$(1)))"
# $(1): build@source@object.
db_entry = $(call db_entry3,$(word 1,$(subst @, ,$(1))),$(word 2,$(subst @, ,$(1))),$(word 3,$(subst @, ,$(1))))
db_entry3 = {"directory": $(call json_str,$(CURDIR)), "file": $(call json_str,$(2)), \
  "output": $(call json_str,$(3)), "command": $(call json_str,$(call build_cmd,$(1),$(2),$(3)))}

.PHONY: compile_commands.json print-cflags
DB_COMPILES = $(filter host-$(NUMERIC)@%,$(COMPILES)) \
  $(filter host-%,$(filter-out host-$(NUMERIC)@%,$(COMPILES))) $(filter-out host-%,$(COMPILES))
compile_commands.json:  ## the command of every compile of every build, for clangd and clang-tidy
	$(file >$@,[$(nl)$(call db_entry,$(firstword $(DB_COMPILES)))$(foreach c,$(wordlist 2,$(words $(DB_COMPILES)),$(DB_COMPILES)),$(comma)$(nl)$(call db_entry,$(c)))$(nl)])
	@echo "$@: $(words $(DB_COMPILES)) compiles"

# The host build's flags (NUMERIC's mode), which the pytest shims compile with
# (tests/python/conftest.py).
print-cflags:  ## print the host build's compile flags (NUMERIC's mode)
	@echo '$(strip $(BUILD_CFLAGS_host-$(NUMERIC)) $(WARN))'
