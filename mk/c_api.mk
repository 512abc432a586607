# The C API's tests: tests/c_api_test.c and the documented example docs/examples/c_api_example.c,
# compiled as C11 by gcc (so the header is proved to be C) and linked into the test binary, where
# tests/c_api_runner_test.cc runs them.
C_API_CC ?= gcc
C_API_CFLAGS := -std=c11 $(OPT) $(DEBUGINFO) -Wall -Wextra -pedantic -Werror -I. $(SANFLAGS)
C_API_TEST_OBJS := $(BUILD)/obj/tests/c_api_test.c.o $(BUILD)/obj/docs/examples/c_api_example.c.o
$(BUILD)/obj/%.c.o: %.c
	@mkdir -p $(@D)
	$(C_API_CC) $(C_API_CFLAGS) -MMD -MP -c $< -o $@
TEST_OBJS += $(C_API_TEST_OBJS)
$(TEST_BIN): $(C_API_TEST_OBJS)
