/* Checks with a message for the cmocka tests (include after <cmocka.h> and <math.h>): CHECKF fails
 * the test printing a formatted message, assert_near compares two doubles within an absolute
 * tolerance and prints both to 17 digits. */
#ifndef PF_TEST_CHECK_H
#define PF_TEST_CHECK_H

#define CHECKF(cond, ...)                                                                          \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            print_error(__VA_ARGS__);                                                              \
            print_error("\n");                                                                     \
            fail_msg("%s", #cond);                                                                 \
        }                                                                                          \
    } while (0)

#define assert_near(a, b, tol)                                                                     \
    do {                                                                                           \
        double got_ = (a), want_ = (b);                                                            \
        CHECKF(fabs(got_ - want_) <= (tol), "%s = %.17g, expected %.17g", #a, got_, want_);        \
    } while (0)

#endif
