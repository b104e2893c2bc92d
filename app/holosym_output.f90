!> Files and programs of the `holosym` tool, handled so that failures are seen and no
!! text ever reaches a shell.
!!
!! Output: a full disk, a full device (/dev/full), a closed standard output or a file-size
!! limit make the command fail. gfortran's units do not report these: a `write`, `flush`
!! or `close` to a full device returns iostat 0 (gfortran 12). So results go through
!! `output_t`, which buffers lines and writes them with write(2), and on `close` forces a
!! regular file to its device (fsync(2)) and checks close(2); the first failure is kept
!! with its system error text.
!!
!! Input: `read_text_file` reads a whole text file with the library's `read_text_lines`,
!! refusing what is not text (a NUL or other control byte, as /dev/zero or /dev/full give)
!! and lines beyond 1 MiB, so that no device or binary file makes a reader loop or exhaust
!! memory.
!!
!! Directories are created with mkdir(2), files removed with unlink(2) and other programs
!! run with posix_spawnp(3) (`run_program`), never through a shell: a path or argument
!! with quotes, semicolons or `$(...)` is passed on as it is. The POSIX calls are in
!! holosym_posix.c.
module holosym_output
    use, intrinsic :: iso_c_binding, only: c_int, c_long, c_char, c_null_char
    use, intrinsic :: iso_fortran_env, only: error_unit, int64
    use holosym_status_codes, only: holosym_status_t, HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT
    use holosym_text_file, only: text_t => text_line_t, read_text_lines, TEXT_NOT_ACCEPTED, &
        error_text
    implicit none
    private

    public :: output_t, open_output, standard_output, make_directories, error_text
    public :: keep_standard_streams, remove_file, run_program, command_text, text_t
    public :: read_text_file, append_text, write_lines, same_file

    !> Bytes collected before a write(2).
    integer, parameter :: buffer_size = 65536

    !> A text output: standard output or a file opened by `open_output`.
    type :: output_t
        integer(c_int) :: fd = -1        !! descriptor (-1: not open)
        character(len=:), allocatable :: name !! "standard output" or the path, for messages
        character(len=buffer_size) :: buffer  !! bytes not written yet
        integer :: used = 0               !! bytes in `buffer`
        integer :: error = 0              !! errno of the first failure, 0 if none
        logical :: owned = .false.        !! opened here: `close` closes the descriptor
        !> Complete lines that reached the output (a write that failed may have left part
        !! of a line after them).
        integer(int64) :: lines_written = 0
    contains
        !> Append a line (the text and a newline).
        procedure :: line => output_line
        !> Write the buffered bytes.
        procedure :: flush => output_flush
        !> Flush, force a regular file to its device and close it; the outcome.
        procedure :: close => output_close
        !> True when a write has failed.
        procedure :: failed => output_failed
    end type output_t

    interface
        integer(c_int) function c_open_write(path, fd) bind(C, name="holosym_open_write")
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: path(*)
            integer(c_int), intent(out) :: fd
        end function c_open_write

        integer(c_int) function c_write_all(fd, buffer, n, done) &
            bind(C, name="holosym_write_all")
            import :: c_int, c_char, c_long
            integer(c_int), value :: fd
            character(kind=c_char), intent(in) :: buffer(*)
            integer(c_long), value :: n
            integer(c_long), intent(out) :: done
        end function c_write_all

        integer(c_int) function c_same_file(a, b) bind(C, name="holosym_same_file")
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: a(*)
            character(kind=c_char), intent(in) :: b(*)
        end function c_same_file

        integer(c_int) function c_sync(fd) bind(C, name="holosym_sync")
            import :: c_int
            integer(c_int), value :: fd
        end function c_sync

        integer(c_int) function c_close(fd) bind(C, name="holosym_close")
            import :: c_int
            integer(c_int), value :: fd
        end function c_close

        integer(c_int) function c_make_directories(path) &
            bind(C, name="holosym_make_directories")
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: path(*)
        end function c_make_directories

        subroutine c_keep_standard_streams() bind(C, name="holosym_keep_standard_streams")
        end subroutine c_keep_standard_streams

        integer(c_int) function c_remove_file(path) bind(C, name="holosym_remove_file")
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: path(*)
        end function c_remove_file

        integer(c_int) function c_run_program(args, count, output, exit_code, stage) &
            bind(C, name="holosym_run_program")
            import :: c_int, c_char
            character(kind=c_char), intent(in) :: args(*)
            integer(c_int), value :: count
            character(kind=c_char), intent(in) :: output(*)
            integer(c_int), intent(out) :: exit_code, stage
        end function c_run_program
    end interface

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> Standard output (descriptor 1), not closed by `close`.
    function standard_output() result(out)
        type(output_t) :: out
        out%fd = 1
        out%name = "standard output"
        out%owned = .false.
    end function standard_output

    !> Create or truncate `path` for writing. Failure: HOLOSYM_INVALID_ARGUMENT with the
    !! path and the system's reason.
    subroutine open_output(path, out, status)
        character(len=*), intent(in) :: path          !! the file
        type(output_t), intent(out) :: out            !! the output
        type(holosym_status_t), intent(out) :: status !! outcome
        integer(c_int) :: error
        out%name = path
        error = c_open_write(c_text(path), out%fd)
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        if (error /= 0) then
            out%fd = -1
            status%code = HOLOSYM_INVALID_ARGUMENT
            status%message = "cannot open '" // path // "': " // error_text(int(error))
            return
        end if
        out%owned = .true.
    end subroutine open_output

    !> Append `text` and a newline; writes when the buffer is full. After a failure nothing
    !! more is written.
    subroutine output_line(self, text)
        class(output_t), intent(inout) :: self
        character(len=*), intent(in) :: text !! the line, without its end
        call put(self, text)
        call put(self, new_line("a"))
    end subroutine output_line

    !> Append bytes to the buffer, writing it out whenever it fills.
    subroutine put(self, text)
        class(output_t), intent(inout) :: self
        character(len=*), intent(in) :: text
        integer :: first, chunk
        first = 1
        do while (first <= len(text) .and. self%error == 0)
            chunk = min(len(text) - first + 1, buffer_size - self%used)
            self%buffer(self%used + 1:self%used + chunk) = text(first:first + chunk - 1)
            self%used = self%used + chunk
            first = first + chunk
            if (self%used == buffer_size) call output_flush(self)
        end do
    end subroutine put

    !> Write the buffered bytes (nothing after a failure, or when not open).
    subroutine output_flush(self)
        class(output_t), intent(inout) :: self
        integer(c_int) :: error
        integer(c_long) :: done
        integer :: k
        if (self%used == 0 .or. self%error /= 0) return
        if (self%fd < 0) then
            self%error = 9  ! EBADF
            return
        end if
        error = c_write_all(self%fd, self%buffer, int(self%used, c_long), done)
        do k = 1, int(done)
            if (self%buffer(k:k) == new_line("a")) self%lines_written = self%lines_written + 1
        end do
        self%used = 0
        if (error /= 0) self%error = int(error)
    end subroutine output_flush

    !> Flush, force a regular file's data to its device and close a file opened here.
    !! Failure (the first write, sync or close error): HOLOSYM_INVALID_ARGUMENT with the
    !! output's name and the system's reason.
    subroutine output_close(self, status)
        class(output_t), intent(inout) :: self
        type(holosym_status_t), intent(out) :: status !! outcome
        integer(c_int) :: error
        call output_flush(self)
        if (self%fd >= 0 .and. self%error == 0) then
            error = c_sync(self%fd)
            if (error /= 0) self%error = int(error)
        end if
        if (self%owned .and. self%fd >= 0) then
            error = c_close(self%fd)
            if (error /= 0 .and. self%error == 0) self%error = int(error)
            self%fd = -1
            self%owned = .false.
        end if
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        if (self%error /= 0) then
            status%code = HOLOSYM_INVALID_ARGUMENT
            status%message = "cannot write " // self%name // ": " // error_text(self%error)
        end if
    end subroutine output_close

    !> True when a write has failed.
    pure logical function output_failed(self)
        class(output_t), intent(in) :: self
        output_failed = self%error /= 0
    end function output_failed

    !> Create the directory `path` and its missing parents (mkdir -p, without a shell).
    !! Failure: HOLOSYM_INVALID_ARGUMENT naming the path and the system's reason.
    subroutine make_directories(path, status)
        character(len=*), intent(in) :: path          !! the directory
        type(holosym_status_t), intent(out) :: status !! outcome
        integer(c_int) :: error
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        error = c_make_directories(c_text(path))
        if (error /= 0) then
            status%code = HOLOSYM_INVALID_ARGUMENT
            status%message = "cannot create directory '" // path // "': " // &
                error_text(int(error))
        end if
    end subroutine make_directories

    !> Whether the paths `a` and `b` name one file: the same text, the same device and
    !! inode when both exist, else the same name in the same resolved directory.
    logical function same_file(a, b)
        character(len=*), intent(in) :: a, b !! the paths
        same_file = c_same_file(c_text(a), c_text(b)) /= 0
    end function same_file

    !> Remove the file `path` (unlink(2), without a shell); a missing file is no error.
    !! Failure: HOLOSYM_INVALID_ARGUMENT naming the path and the system's reason.
    subroutine remove_file(path, status)
        character(len=*), intent(in) :: path          !! the file
        type(holosym_status_t), intent(out) :: status !! outcome
        integer(c_int) :: error
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        error = c_remove_file(c_text(path))
        if (error /= 0) then
            status%code = HOLOSYM_INVALID_ARGUMENT
            status%message = "cannot remove '" // path // "': " // error_text(int(error))
        end if
    end subroutine remove_file

    !> Run the program `argv(1)` with the arguments `argv(2:)` and wait for it. No shell is
    !! involved: every argument reaches the program exactly as given (quotes, semicolons,
    !! `$(...)` included), and the program is found on PATH unless its name has a '/'.
    !! Its standard output goes to the file `output` (created or truncated), or to this
    !! process's standard error when `output` is "" (so that it never mixes with the
    !! results on standard output). `exit_code`: the program's exit status, 128 + the
    !! signal that ended it, or -1 when it did not run. Failure to start it or to open
    !! `output` (not the program's own exit status): HOLOSYM_INVALID_ARGUMENT with the
    !! program or file and the system's reason.
    subroutine run_program(argv, output, exit_code, status)
        type(text_t), intent(in) :: argv(:)           !! the program and its arguments
        character(len=*), intent(in) :: output        !! file for its standard output, or ""
        integer, intent(out) :: exit_code             !! its exit status
        type(holosym_status_t), intent(out) :: status !! outcome of starting it
        character(len=:), allocatable :: packed
        integer(c_int) :: error, code, stage
        integer :: k
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        exit_code = -1
        if (size(argv) == 0) then
            status%code = HOLOSYM_INVALID_ARGUMENT
            status%message = "run_program: no program given"
            return
        end if
        packed = ""
        do k = 1, size(argv)
            if (index(argv(k)%text, c_null_char) > 0) then
                status%code = HOLOSYM_INVALID_ARGUMENT
                status%message = "argument " // int_text(k) // " of '" // argv(1)%text // &
                    "' holds a NUL character"
                return
            end if
            packed = packed // argv(k)%text // c_null_char
        end do
        ! Messages written so far come before the program's.
        flush (error_unit, iostat=k)
        error = c_run_program(packed, int(size(argv), c_int), c_text(output), code, stage)
        exit_code = int(code)
        if (error /= 0) then
            status%code = HOLOSYM_INVALID_ARGUMENT
            select case (stage)
            case (1)
                status%message = "cannot open '" // output // "': " // error_text(int(error))
            case (2)
                status%message = "cannot run '" // argv(1)%text // "': " // &
                    error_text(int(error))
            case default
                status%message = "waiting for '" // argv(1)%text // "' failed: " // &
                    error_text(int(error))
            end select
        end if
    end subroutine run_program

    !> Append `text` to `list` (a program's arguments, a file's lines).
    pure subroutine append_text(list, text)
        type(text_t), allocatable, intent(inout) :: list(:) !! grows by one element
        character(len=*), intent(in) :: text                !! the new last element
        type(text_t), allocatable :: longer(:)
        integer :: k
        if (.not. allocated(list)) allocate (list(0))
        allocate (longer(size(list) + 1))
        do k = 1, size(list)
            call move_alloc(list(k)%text, longer(k)%text)
        end do
        longer(size(longer))%text = text
        call move_alloc(longer, list)
    end subroutine append_text

    !> A program and its arguments as one line for messages: arguments with characters
    !! other than letters, digits and _./=:,+- shown in single quotes (for reading only:
    !! `run_program` never hands this text to a shell).
    pure function command_text(argv) result(text)
        type(text_t), intent(in) :: argv(:) !! the program and its arguments
        character(len=:), allocatable :: text
        character(len=*), parameter :: plain = "abcdefghijklmnopqrstuvwxyz" // &
            "ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_./=:,+-"
        integer :: k, c
        text = ""
        do k = 1, size(argv)
            if (k > 1) text = text // " "
            if (len(argv(k)%text) > 0 .and. verify(argv(k)%text, plain) == 0) then
                text = text // argv(k)%text
            else
                text = text // "'"
                do c = 1, len(argv(k)%text)
                    if (argv(k)%text(c:c) == "'") then
                        text = text // "'\''"
                    else
                        text = text // argv(k)%text(c:c)
                    end if
                end do
                text = text // "'"
            end if
        end do
    end function command_text

    !> Write `lines` to `path` (replaced) through `output_t`. Failure:
    !! HOLOSYM_INVALID_ARGUMENT naming the file and the system's reason.
    subroutine write_lines(path, lines, status)
        character(len=*), intent(in) :: path
        type(text_t), intent(in) :: lines(:)
        type(holosym_status_t), intent(inout) :: status
        type(output_t) :: file
        integer :: k
        call open_output(path, file, status)
        if (.not. status%ok()) return
        do k = 1, size(lines)
            call file%line(lines(k)%text)
        end do
        call file%close(status)
    end subroutine write_lines

    !> Every line of the text file `path`, without line ends (a last line without its end
    !! is kept). Failure (HOLOSYM_INVALID_ARGUMENT, naming the file and the line; `lines`
    !! then empty): the file cannot be opened or read, a line holds a control character
    !! other than a tab or a carriage return (a NUL from a device such as /dev/zero or
    !! /dev/full, a binary file), or a line is longer than 1 MiB. The reading is the
    !! library's `read_text_lines` (holosym_text_file); this adds the file to its message.
    subroutine read_text_file(path, lines, status)
        character(len=*), intent(in) :: path                 !! the file
        type(text_t), allocatable, intent(out) :: lines(:)   !! its lines
        type(holosym_status_t), intent(out) :: status        !! outcome
        character(len=:), allocatable :: message
        integer :: ios
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        call read_text_lines(path, lines, ios, message)
        if (ios == 0) return
        status%code = HOLOSYM_INVALID_ARGUMENT
        if (ios == TEXT_NOT_ACCEPTED) then
            status%message = path // ": " // message
        else
            status%message = "cannot read '" // path // "': " // message
        end if
    end subroutine read_text_file

    !> An integer as text.
    pure function int_text(value) result(text)
        integer, intent(in) :: value
        character(len=:), allocatable :: text
        character(len=16) :: buffer
        write (buffer, '(i0)') value
        text = trim(buffer)
    end function int_text

    !> Keep closed standard output and error from being reused by files, and make a
    !! file-size limit fail a write instead of killing the process (see
    !! holosym_keep_standard_streams): writes then fail visibly.
    subroutine keep_standard_streams()
        call c_keep_standard_streams()
    end subroutine keep_standard_streams

    !> `text` NUL-terminated for C.
    pure function c_text(text) result(terminated)
        character(len=*), intent(in) :: text
        character(kind=c_char, len=len(text) + 1) :: terminated
        terminated = text // c_null_char
    end function c_text

end module holosym_output

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_output) holosym_output_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_output_app
