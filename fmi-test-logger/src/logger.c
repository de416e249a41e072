/* A C variadic fmi2CallbackLogger, as importers write them: it formats the message with
 * vsnprintf, so it proves the FMU passes "%s" and the message, and hands the result to Rust. */
#include <stdarg.h>
#include <stdio.h>

void fmi_test_record(void *env, const char *instance, int status, const char *category, const char *message);

void fmi_test_logger(void *env, const char *instance, int status, const char *category, const char *format, ...) {
    char buffer[8192];
    va_list args;
    va_start(args, format);
    vsnprintf(buffer, sizeof buffer, format, args);
    va_end(args);
    fmi_test_record(env, instance, status, category, buffer);
}
