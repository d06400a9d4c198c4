/* Fault injection for tests/test_session_journal.py: preloaded (LD_PRELOAD), it counts every write to a regular file
 * (write, pwrite, pwrite64, writev: Python's and HDF5's alike) and, once armed, makes one fail:
 *   mode 1 "disk full from write N": write N writes half its bytes, it and every later write fail with ENOSPC;
 *   mode 2 "one failed write N":     write N fails with EIO, the later ones succeed;
 *   mode 3 "disk full at byte B":    the write that crosses byte B (counted over all files) writes up to B, the later
 *                                    ones fail with ENOSPC.
 * Armed through ctypes (failing_writes_arm(mode, at); failing_writes_count() and failing_writes_bytes() tell what was
 * written) or, for a whole process, by the environment: FAILING_WRITES_MODE=1|2|3 FAILING_WRITES_AT=N. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdlib.h>
#include <errno.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/uio.h>
#include <unistd.h>

static long writes = 0, bytes = 0, mode = 0, at = 0, failed = 0;

void failing_writes_arm(long new_mode, long new_at) { mode = new_mode; at = new_at; writes = 0; bytes = 0; failed = 0; }
long failing_writes_count(void) { return writes; }
long failing_writes_bytes(void) { return bytes; }

__attribute__((constructor)) static void arm_from_environment(void) {
    const char *new_mode = getenv("FAILING_WRITES_MODE"), *new_at = getenv("FAILING_WRITES_AT");
    if (new_mode && new_at) failing_writes_arm(atol(new_mode), atol(new_at));
}

static int regular(int fd) {
    struct stat st;
    return fstat(fd, &st) == 0 && S_ISREG(st.st_mode);
}

/* How many of n bytes may be written (n: all), or -1 with errno set. */
static ssize_t allowed(int fd, size_t n) {
    if (!regular(fd)) return (ssize_t)n;
    writes++;
    if (mode == 1 && writes >= at) {
        if (writes == at && n > 1) { bytes += n / 2; return (ssize_t)(n / 2); }
        errno = ENOSPC; return -1;
    }
    if (mode == 2 && writes == at) { errno = EIO; return -1; }
    if (mode == 3) {
        if (failed || bytes >= at) { failed = 1; errno = ENOSPC; return -1; }
        if (bytes + (long)n > at) { size_t part = (size_t)(at - bytes); bytes = at; failed = 1;
                                    if (part == 0) { errno = ENOSPC; return -1; } return (ssize_t)part; }
    }
    bytes += (long)n;
    return (ssize_t)n;
}

static ssize_t real_write(int fd, const void *buf, size_t n) {
    static ssize_t (*real)(int, const void *, size_t);
    if (!real) real = dlsym(RTLD_NEXT, "write");
    return real(fd, buf, n);
}

ssize_t write(int fd, const void *buf, size_t n) {
    ssize_t k = allowed(fd, n);
    return k < 0 ? -1 : real_write(fd, buf, (size_t)k);
}

ssize_t pwrite(int fd, const void *buf, size_t n, off_t offset) {
    static ssize_t (*real)(int, const void *, size_t, off_t);
    if (!real) real = dlsym(RTLD_NEXT, "pwrite");
    ssize_t k = allowed(fd, n);
    return k < 0 ? -1 : real(fd, buf, (size_t)k, offset);
}

ssize_t pwrite64(int fd, const void *buf, size_t n, off_t offset) {
    static ssize_t (*real)(int, const void *, size_t, off_t);
    if (!real) real = dlsym(RTLD_NEXT, "pwrite64");
    ssize_t k = allowed(fd, n);
    return k < 0 ? -1 : real(fd, buf, (size_t)k, offset);
}

ssize_t writev(int fd, const struct iovec *iov, int count) {
    static ssize_t (*real)(int, const struct iovec *, int);
    if (!real) real = dlsym(RTLD_NEXT, "writev");
    size_t n = 0;
    for (int i = 0; i < count; i++) n += iov[i].iov_len;
    ssize_t k = allowed(fd, n);
    if (k < 0) return -1;
    if ((size_t)k == n) return real(fd, iov, count);
    return real_write(fd, iov[0].iov_base, (size_t)k < iov[0].iov_len ? (size_t)k : iov[0].iov_len);
}
