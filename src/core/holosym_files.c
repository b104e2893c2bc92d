/* POSIX services of the library's text files (see holosym_text_file.f90): streams whose
 * every failure returns the system's error number (the C library sets errno, which
 * Fortran cannot read portably), exclusive locks on a file held for a whole run
 * (flock(2): a lock belongs to its open file description, so the process's other opens
 * and closes of the same file leave it alone, unlike fcntl(2) locks), truncation of a
 * locked file, and the text of an error number. Every function returns 0 or an errno
 * value. */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

/* An errno value after a failed call that may not have set one. */
static int failure(void)
{
    return errno != 0 ? errno : EIO;
}

/* fopen(3) with `mode` ("wx", "w" or "a"); the stream in *stream (NULL on failure). */
int holosym_stream_open(const char *path, const char *mode, FILE **stream)
{
    errno = 0;
    *stream = fopen(path, mode);
    return *stream == NULL ? failure() : 0;
}

/* Write n bytes to the stream (buffered). */
int holosym_stream_write(FILE *stream, const char *buffer, long n)
{
    errno = 0;
    if (n > 0 && fwrite(buffer, 1, (size_t)n, stream) != (size_t)n)
        return failure();
    return 0;
}

/* Push the buffered bytes to the file. */
int holosym_stream_flush(FILE *stream)
{
    errno = 0;
    return fflush(stream) != 0 ? failure() : 0;
}

/* Flush and close the stream (closed in any case); the first failure. */
int holosym_stream_close(FILE *stream)
{
    int error = holosym_stream_flush(stream);
    errno = 0;
    if (fclose(stream) != 0 && error == 0)
        error = failure();
    return error;
}

/* Open `path` for reading and writing (created, and refused if it exists, when `create`
 * is nonzero) and take an exclusive flock(2) on it without waiting; the descriptor,
 * which holds the lock until holosym_unlock_file, in *fd. EWOULDBLOCK: another open file
 * description (another run) holds the lock. When the path was renamed over between the
 * open and the lock, the file now at the path is locked instead. */
int holosym_lock_file(const char *path, int create, int *fd)
{
    struct stat locked, named;
    int f, error;
    for (;;) {
        do {
            f = open(path, O_RDWR | O_CLOEXEC | (create ? O_CREAT | O_EXCL : 0), 0666);
        } while (f < 0 && errno == EINTR);
        if (f < 0) {
            *fd = -1;
            return errno;
        }
        while (flock(f, LOCK_EX | LOCK_NB) != 0) {
            if (errno == EINTR)
                continue;
            error = errno == EAGAIN ? EWOULDBLOCK : errno;
            close(f);
            *fd = -1;
            return error;
        }
        if (create || (fstat(f, &locked) == 0 && stat(path, &named) == 0 &&
                       locked.st_dev == named.st_dev && locked.st_ino == named.st_ino)) {
            *fd = f;
            return 0;
        }
        close(f);
    }
}

/* Release the lock of holosym_lock_file (close its descriptor). */
int holosym_unlock_file(int fd)
{
    if (close(fd) != 0 && errno != EINTR)
        return errno;
    return 0;
}

/* Cut the file open on fd to its first `length` bytes. */
int holosym_truncate_file(int fd, long long length)
{
    int result;
    do {
        result = ftruncate(fd, (off_t)length);
    } while (result != 0 && errno == EINTR);
    return result != 0 ? errno : 0;
}

/* Whether the lock-refused error of holosym_lock_file is `error` (1 or 0). */
int holosym_lock_is_held(int error)
{
    return error == EWOULDBLOCK || error == EAGAIN;
}

/* The text of an errno value, into buffer (NUL-terminated, at most size bytes). */
void holosym_error_text(int error, char *buffer, int size)
{
    const char *text;
    if (size <= 0)
        return;
    text = strerror(error);
    strncpy(buffer, text ? text : "unknown error", (size_t)size - 1);
    buffer[size - 1] = '\0';
}
