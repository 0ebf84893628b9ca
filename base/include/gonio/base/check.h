#pragma once

// Always-on checks of internal invariants. A failed check prints the expression, the place and the
// values, and aborts: it is a bug, never an expected failure (those return gonio::Expected).

#include <cstdio>
#include <cstdlib>
#include <sstream>

#define GONIO_CHECK(cond)                                                                 \
    do {                                                                                  \
        if (!(cond)) {                                                                    \
            std::fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond); \
            std::abort();                                                                 \
        }                                                                                 \
    } while (false)

/// GONIO_CHECK_MSG(x > 0, "x = " << x): the message is streamed only on failure.
#define GONIO_CHECK_MSG(cond, stream_expr)                 \
    do {                                                   \
        if (!(cond)) {                                     \
            std::ostringstream gonio_check_os_;            \
            gonio_check_os_ << stream_expr;                \
            std::fprintf(stderr,                           \
                         "%s:%d: check failed: %s (%s)\n", \
                         __FILE__,                         \
                         __LINE__,                         \
                         #cond,                            \
                         gonio_check_os_.str().c_str());   \
            std::abort();                                  \
        }                                                  \
    } while (false)
