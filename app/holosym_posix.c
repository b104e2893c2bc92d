/* POSIX services of the holosym tool (see app/holosym_output.f90): writes whose failures
 * are seen (write(2), fsync(2) and close(2) results; gfortran's own units drop them),
 * directories created and files removed without a shell (mkdir(2), unlink(2)), other
 * programs run without a shell (posix_spawnp(3): each argument reaches the program as
 * given), and the standard streams kept on their descriptors (error texts are the
 * library's: src/core/holosym_files.c). Every function returns 0 or an errno value. */
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <spawn.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

extern char **environ;

/* Open (create or truncate) a file for writing; the descriptor in *fd. */
int holosym_open_write(const char *path, int *fd)
{
    int f;
    do {
        f = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    } while (f < 0 && errno == EINTR);
    if (f < 0) {
        *fd = -1;
        return errno;
    }
    *fd = f;
    return 0;
}

/* `path` with its directory resolved (realpath(3)) into `resolved` (PATH_MAX bytes): the
 * file itself need not exist. 0 when the directory cannot be resolved. */
static int resolve_in_directory(const char *path, char *resolved)
{
    char directory[PATH_MAX], real_directory[PATH_MAX];
    const char *slash = strrchr(path, '/');
    const char *name = slash ? slash + 1 : path;
    size_t length = slash ? (size_t)(slash - path) : 1;
    if (length >= sizeof directory)
        return 0;
    if (slash == NULL)
        memcpy(directory, ".", 2);
    else if (length == 0)
        memcpy(directory, "/", 2);
    else {
        memcpy(directory, path, length);
        directory[length] = '\0';
    }
    if (realpath(directory, real_directory) == NULL)
        return 0;
    return snprintf(resolved, PATH_MAX, "%s/%s", real_directory, name) < PATH_MAX;
}

/* Write all n bytes, retrying partial writes and interrupted calls; the bytes that
 * reached the file in *done (all n on success, fewer on a failure). */
int holosym_write_all(int fd, const char *buffer, long n, long *done)
{
    *done = 0;
    while (*done < n) {
        ssize_t w = write(fd, buffer + *done, (size_t)(n - *done));
        if (w < 0) {
            if (errno == EINTR)
                continue;
            return errno;
        }
        if (w == 0)
            return EIO;
        *done += (long)w;
    }
    return 0;
}

/* Whether two paths name one file (1) or not (0): the same string; when both exist, the
 * same device and inode (links, "./x" and "x", another spelling of the directory);
 * otherwise the same file name in the same (resolved) directory. */
int holosym_same_file(const char *a, const char *b)
{
    struct stat info_a, info_b;
    char resolved_a[PATH_MAX], resolved_b[PATH_MAX];
    if (strcmp(a, b) == 0)
        return 1;
    if (stat(a, &info_a) == 0 && stat(b, &info_b) == 0)
        return info_a.st_dev == info_b.st_dev && info_a.st_ino == info_b.st_ino;
    if (!resolve_in_directory(a, resolved_a) || !resolve_in_directory(b, resolved_b))
        return 0;
    return strcmp(resolved_a, resolved_b) == 0;
}

/* Force the data of a regular file to its device (a full file system may report
 * ENOSPC only here); other kinds of files (pipes, terminals, devices) need nothing. */
int holosym_sync(int fd)
{
    struct stat info;
    if (fstat(fd, &info) != 0)
        return errno;
    if (!S_ISREG(info.st_mode))
        return 0;
    if (fsync(fd) != 0 && errno != EINVAL && errno != EROFS)
        return errno;
    return 0;
}

/* Close a descriptor (its last chance to report a deferred write error). */
int holosym_close(int fd)
{
    if (close(fd) != 0 && errno != EINTR)
        return errno;
    return 0;
}

/* mkdir -p: create each missing directory of the path (mode 0777 less the umask). */
int holosym_make_directories(const char *path)
{
    char partial[4096];
    size_t length = strlen(path), i;
    struct stat info;
    if (length == 0)
        return ENOENT;
    if (length >= sizeof partial)
        return ENAMETOOLONG;
    for (i = 1; i <= length; i++) {
        if (i < length && path[i] != '/')
            continue;
        memcpy(partial, path, i);
        partial[i] = '\0';
        if (partial[i - 1] == '/')
            continue;
        if (mkdir(partial, 0777) != 0) {
            if (errno != EEXIST)
                return errno;
            if (stat(partial, &info) != 0)
                return errno;
            if (!S_ISDIR(info.st_mode))
                return ENOTDIR;
        }
    }
    return 0;
}

/* Remove a file (unlink(2)); a file that does not exist is no error (rm -f). */
int holosym_remove_file(const char *path)
{
    if (unlink(path) != 0 && errno != ENOENT)
        return errno;
    return 0;
}

/* Run a program and wait for it, without a shell. `args` holds `count` >= 1
 * NUL-terminated arguments one after the other, the first the program (found on PATH
 * when it has no '/', as execvp(3) does). The program's standard output goes to the file
 * `output` (created or truncated) or, when `output` is "", to this process's standard
 * error; standard input and error are inherited. *exit_code: the program's exit status,
 * or 128 + the signal that ended it. *stage says what failed: 1 opening `output`, 2
 * starting the program, 3 waiting for it (0: nothing). */
int holosym_run_program(const char *args, int count, const char *output, int *exit_code,
                        int *stage)
{
    char **argv;
    const char *next = args;
    posix_spawn_file_actions_t actions;
    pid_t pid;
    int i, fd = -1, error, wait_status;
    *exit_code = -1;
    *stage = 2;
    if (count < 1)
        return EINVAL;
    argv = malloc(((size_t)count + 1) * sizeof *argv);
    if (argv == NULL)
        return ENOMEM;
    for (i = 0; i < count; i++) {
        argv[i] = (char *)next;
        next += strlen(next) + 1;
    }
    argv[count] = NULL;
    if (output[0] != '\0') {
        do {
            fd = open(output, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
        } while (fd < 0 && errno == EINTR);
        if (fd < 0) {
            error = errno;
            free(argv);
            *stage = 1;
            return error;
        }
    }
    error = posix_spawn_file_actions_init(&actions);
    if (error == 0) {
        error = posix_spawn_file_actions_adddup2(&actions, fd >= 0 ? fd : 2, 1);
        if (error == 0)
            error = posix_spawnp(&pid, argv[0], &actions, NULL, argv, environ);
        posix_spawn_file_actions_destroy(&actions);
    }
    if (fd >= 0)
        close(fd);
    free(argv);
    if (error != 0)
        return error;
    *stage = 3;
    while (waitpid(pid, &wait_status, 0) < 0) {
        if (errno != EINTR)
            return errno;
    }
    *stage = 0;
    if (WIFEXITED(wait_status))
        *exit_code = WEXITSTATUS(wait_status);
    else if (WIFSIGNALED(wait_status))
        *exit_code = 128 + WTERMSIG(wait_status);
    return 0;
}

/* A closed standard output or error (descriptor 1 or 2) is reopened on /dev/null for
 * reading only: writes to it then fail (EBADF) instead of succeeding unseen, and no file
 * opened later takes its number. A file-size limit (ulimit -f) makes write(2) fail with
 * EFBIG, like a full disk, instead of killing the process with SIGXFSZ. */
void holosym_keep_standard_streams(void)
{
    int fd;
    signal(SIGXFSZ, SIG_IGN);
    for (fd = 1; fd <= 2; fd++) {
        if (fcntl(fd, F_GETFD) == -1 && errno == EBADF) {
            int f = open("/dev/null", O_RDONLY);
            if (f >= 0 && f != fd) {
                dup2(f, fd);
                close(f);
            }
        }
    }
}
