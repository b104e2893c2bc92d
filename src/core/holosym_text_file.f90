!> category: internal module (use holosym)
!! Text files written through the C library's streams (fopen, fwrite, fflush, fclose), so
!! that a write that does not reach the file is seen: a full disk or device (/dev/full),
!! a file-size limit. Fortran units cannot be trusted with that: gfortran 12 reports none
!! of these on write, flush or close (iostat 0), and LLVM flang's runtime stops the
!! program on them even when iostat is given. The files of the ensemble (results, timing
!! log, samples) and of `trajectory_writer` go through `text_file_t`.
!!
!! Every failure names the file, the operation and the system's reason (the text of the
!! error number, which the C helpers of src/core/holosym_files.c return).
!!
!! `file_lock_t` holds an exclusive lock on a file (flock) for as long as a run writes it,
!! so that two runs cannot write the same file at once.
!!
!! Text files are read by `read_text_lines`, which refuses what is not text (a NUL or
!! other control byte, as /dev/zero or /dev/full give) and lines beyond
!! `max_text_line_length`, so that no input can make a reader loop or exhaust memory.
module holosym_text_file
    use, intrinsic :: iso_c_binding, only: c_ptr, c_null_ptr, c_associated, c_char, c_int, &
        c_long, c_long_long, c_null_char
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_status_codes, only: int_str
    implicit none
    private

    public :: text_file_t, text_line_t, file_lock_t, read_text_lines, error_text, &
        printable, max_text_line_length, control_position
    public :: TEXT_CANNOT_OPEN, TEXT_CANNOT_READ, TEXT_NOT_ACCEPTED

    !> Longest line `read_text_lines` accepts (1 MiB).
    integer, parameter :: max_text_line_length = 1048576

    !> Failures of `read_text_lines` (its `ios`): the file cannot be opened, a read failed,
    !! or the content is refused (not text, or a line too long).
    integer, parameter :: TEXT_CANNOT_OPEN = 1, TEXT_CANNOT_READ = 2, TEXT_NOT_ACCEPTED = 3

    !> One line of a text file.
    type :: text_line_t
        character(len=:), allocatable :: text
    end type text_line_t

    !> A text file open for writing; the first failure is kept.
    type :: text_file_t
        type(c_ptr), private :: stream = c_null_ptr
        character(len=:), allocatable, private :: path
        !> "" or what failed first, naming the file.
        character(len=:), allocatable :: failure
    contains
        !> Open `path`: "new" (must not exist), "replace" or "append".
        procedure :: open => text_open
        !> Write a line (the text and a newline); nothing after a failure.
        procedure :: line => text_line
        !> Push the written lines to the file.
        procedure :: flush => text_flush
        !> Flush and close; true when every line reached the file.
        procedure :: close => text_close
        !> True when a write, flush or close has failed.
        procedure :: failed => text_failed
    end type text_file_t

    !> An exclusive lock on a file (flock), held from `acquire` to `release` or the end of
    !! the process.
    type :: file_lock_t
        integer(c_int), private :: fd = -1
    contains
        !> Open the file (or create it) and lock it, not waiting.
        procedure :: acquire => lock_acquire
        !> Cut the locked file to a length.
        procedure :: truncate => lock_truncate
        !> Release the lock.
        procedure :: release => lock_release
        !> Whether the lock is held.
        procedure :: held => lock_held
    end type file_lock_t

    interface
        integer(c_int) function c_stream_open(path, mode, stream) &
            bind(C, name="holosym_stream_open")
            import :: c_ptr, c_char, c_int
            character(kind=c_char), intent(in) :: path(*)
            character(kind=c_char), intent(in) :: mode(*)
            type(c_ptr), intent(out) :: stream
        end function c_stream_open

        integer(c_int) function c_stream_write(stream, buffer, n) &
            bind(C, name="holosym_stream_write")
            import :: c_ptr, c_char, c_int, c_long
            type(c_ptr), value :: stream
            character(kind=c_char), intent(in) :: buffer(*)
            integer(c_long), value :: n
        end function c_stream_write

        integer(c_int) function c_stream_flush(stream) bind(C, name="holosym_stream_flush")
            import :: c_ptr, c_int
            type(c_ptr), value :: stream
        end function c_stream_flush

        integer(c_int) function c_stream_close(stream) bind(C, name="holosym_stream_close")
            import :: c_ptr, c_int
            type(c_ptr), value :: stream
        end function c_stream_close

        integer(c_int) function c_lock_file(path, create, fd) bind(C, name="holosym_lock_file")
            import :: c_char, c_int
            character(kind=c_char), intent(in) :: path(*)
            integer(c_int), value :: create
            integer(c_int), intent(out) :: fd
        end function c_lock_file

        integer(c_int) function c_unlock_file(fd) bind(C, name="holosym_unlock_file")
            import :: c_int
            integer(c_int), value :: fd
        end function c_unlock_file

        integer(c_int) function c_truncate_file(fd, length) &
            bind(C, name="holosym_truncate_file")
            import :: c_int, c_long_long
            integer(c_int), value :: fd
            integer(c_long_long), value :: length
        end function c_truncate_file

        integer(c_int) function c_lock_is_held(error) bind(C, name="holosym_lock_is_held")
            import :: c_int
            integer(c_int), value :: error
        end function c_lock_is_held

        subroutine c_error_text(error, buffer, size) bind(C, name="holosym_error_text")
            import :: c_int, c_char
            integer(c_int), value :: error
            character(kind=c_char), intent(out) :: buffer(*)
            integer(c_int), value :: size
        end subroutine c_error_text
    end interface

contains

    !> Open `path` for writing: `mode` "new" (refused when the file exists), "replace"
    !! (created or truncated) or "append" (created when missing). False, with `failure`
    !! set to the reason, when it cannot be opened. A file still open is closed first.
    logical function text_open(self, path, mode) result(ok)
        class(text_file_t), intent(inout) :: self
        character(len=*), intent(in) :: path !! the file
        character(len=*), intent(in) :: mode !! "new", "replace" or "append"
        character(len=:), allocatable :: c_mode
        integer(c_int) :: error
        logical :: closed
        if (c_associated(self%stream)) closed = self%close()
        self%path = path
        self%failure = ""
        select case (mode)
        case ("new")
            c_mode = "wx"
        case ("append")
            c_mode = "a"
        case default
            c_mode = "w"
        end select
        error = c_stream_open(path // c_null_char, c_mode // c_null_char, self%stream)
        ok = error == 0
        if (ok) return
        self%stream = c_null_ptr
        if (mode == "new") then
            self%failure = "cannot create '" // path // "': " // error_text(error)
        else
            self%failure = "cannot open '" // path // "' for writing: " // error_text(error)
        end if
    end function text_open

    !> Write `text` and a newline (buffered).
    subroutine text_line(self, text)
        class(text_file_t), intent(inout) :: self
        character(len=*), intent(in) :: text !! the line, without its end
        integer(c_int) :: error
        if (.not. c_associated(self%stream) .or. self%failed()) return
        error = c_stream_write(self%stream, text // new_line("a"), int(len(text) + 1, c_long))
        if (error /= 0) self%failure = "cannot write '" // self%path // "': " // &
            error_text(error)
    end subroutine text_line

    !> Push the buffered lines to the file (a failure is kept).
    subroutine text_flush(self)
        class(text_file_t), intent(inout) :: self
        integer(c_int) :: error
        if (.not. c_associated(self%stream) .or. self%failed()) return
        error = c_stream_flush(self%stream)
        if (error /= 0) self%failure = "cannot write '" // self%path // "': " // &
            error_text(error)
    end subroutine text_flush

    !> Flush and close the file; true when every line written reached it.
    logical function text_close(self) result(ok)
        class(text_file_t), intent(inout) :: self
        integer(c_int) :: error
        if (.not. allocated(self%failure)) self%failure = ""
        if (c_associated(self%stream)) then
            error = c_stream_close(self%stream)
            if (error /= 0 .and. .not. self%failed()) self%failure = "cannot write '" // &
                self%path // "': " // error_text(error)
            self%stream = c_null_ptr
        end if
        ok = .not. self%failed()
    end function text_close

    !> The system's text of an error number (strerror).
    function error_text(error) result(text)
        integer, intent(in) :: error !! an errno value
        character(len=:), allocatable :: text
        character(kind=c_char, len=256) :: buffer
        integer :: ends
        buffer = ""
        call c_error_text(int(error, c_int), buffer, int(len(buffer), c_int))
        ends = index(buffer, c_null_char)
        if (ends == 0) ends = len(buffer) + 1
        text = buffer(:ends - 1)
    end function error_text

    !> Take an exclusive lock on `path` (flock, not waiting) and hold it until `release`;
    !! with `create` the file is created, and refused when it exists. `error`: 0, or the
    !! errno value; `held_elsewhere` is true when another open of the file (another run)
    !! holds the lock. The lock binds only those who take it: this process's own writes
    !! to the file go on.
    subroutine lock_acquire(self, path, create, error, held_elsewhere)
        class(file_lock_t), intent(inout) :: self
        character(len=*), intent(in) :: path    !! the file
        logical, intent(in) :: create           !! create it (it must not exist)
        integer, intent(out) :: error           !! 0 or errno
        logical, intent(out) :: held_elsewhere  !! another run holds the lock
        call self%release()
        error = c_lock_file(path // c_null_char, merge(1_c_int, 0_c_int, create), self%fd)
        held_elsewhere = error /= 0 .and. c_lock_is_held(int(error, c_int)) /= 0
        if (error /= 0) self%fd = -1
    end subroutine lock_acquire

    !> Cut the locked file to its first `length` bytes; 0 or the errno value.
    integer function lock_truncate(self, length) result(error)
        class(file_lock_t), intent(in) :: self
        integer(int64), intent(in) :: length !! bytes kept
        error = c_truncate_file(self%fd, int(length, c_long_long))
    end function lock_truncate

    !> Release the lock (nothing when none is held).
    subroutine lock_release(self)
        class(file_lock_t), intent(inout) :: self
        integer(c_int) :: error
        if (self%fd >= 0) error = c_unlock_file(self%fd)
        self%fd = -1
    end subroutine lock_release

    !> Whether the lock is held.
    pure logical function lock_held(self)
        class(file_lock_t), intent(in) :: self
        lock_held = self%fd >= 0
    end function lock_held

    !> True when a write, flush or close has failed.
    pure logical function text_failed(self)
        class(text_file_t), intent(in) :: self
        text_failed = .false.
        if (allocated(self%failure)) text_failed = len(self%failure) > 0
    end function text_failed

    !> Every line of the text file `path`. `ios` is 0, or TEXT_CANNOT_OPEN (`message`: the
    !! system's reason), TEXT_CANNOT_READ ("line N: reason") or TEXT_NOT_ACCEPTED ("line N:
    !! not text (control character C at column K)" for a control byte other than a tab or
    !! a carriage return, "line N: longer than L characters"); `lines` is then empty. A
    !! last line without its end of line (a write cut short) is kept.
    !!
    !! The bytes are read with stream access and checked as they come: a record-oriented
    !! read would first look for the end of a line that a device never ends. A regular
    !! file is read in blocks of its known size; anything else (a device, a pipe) byte by
    !! byte, so that the first bad byte stops the reading.
    subroutine read_text_lines(path, lines, ios, message)
        character(len=*), intent(in) :: path                     !! the file
        type(text_line_t), allocatable, intent(out) :: lines(:)  !! its lines
        integer, intent(out) :: ios                              !! 0 or TEXT_*
        character(len=:), allocatable, intent(out) :: message    !! "" or why it failed
        integer, parameter :: block = 65536
        character(len=block) :: chunk
        character(len=256) :: io_message
        character(len=:), allocatable :: line
        type(text_line_t), allocatable :: kept(:)
        integer(int64) :: file_size, done
        integer :: unit, count, n, read_status
        logical :: exists
        allocate (lines(0), kept(64))
        count = 0
        ios = 0
        message = ""
        file_size = -1
        inquire (file=path, exist=exists, size=file_size)
        open (newunit=unit, file=path, status="old", action="read", access="stream", &
              form="unformatted", iostat=read_status, iomsg=io_message)
        if (read_status /= 0) then
            call fail(TEXT_CANNOT_OPEN, trim(io_message))
            return
        end if
        done = 0
        line = ""
        do
            if (file_size > 0) then
                if (done >= file_size) exit
                n = int(min(int(block, int64), file_size - done))
            else
                n = 1
            end if
            read (unit, iostat=read_status, iomsg=io_message) chunk(:n)
            if (is_iostat_end(read_status)) exit
            if (read_status /= 0) then
                call fail(TEXT_CANNOT_READ, "line " // int_str(count + 1) // ": " // &
                    trim(io_message))
                close (unit)
                return
            end if
            done = done + n
            call take(chunk(:n))
            if (ios /= 0) then
                close (unit)
                return
            end if
        end do
        close (unit)
        if (len(line) > 0) call keep()
        lines = kept(:count)
    contains
        !> Split bytes into lines, checking each piece.
        subroutine take(text)
            character(len=*), intent(in) :: text
            integer :: first, end_of_line, last, bad
            first = 1
            do while (first <= len(text))
                end_of_line = index(text(first:), new_line("a"))
                last = len(text)
                if (end_of_line > 0) last = first + end_of_line - 2
                bad = control_position(text(first:last))
                if (bad > 0) then
                    call fail(TEXT_NOT_ACCEPTED, "line " // int_str(count + 1) // &
                        ": not text (control character " // &
                        int_str(iachar(text(first + bad - 1:first + bad - 1))) // &
                        " at column " // int_str(len(line) + bad) // ")")
                    return
                end if
                if (len(line) + last - first + 1 > max_text_line_length) then
                    call fail(TEXT_NOT_ACCEPTED, "line " // int_str(count + 1) // &
                        ": longer than " // int_str(max_text_line_length) // " characters")
                    return
                end if
                line = line // text(first:last)
                if (end_of_line == 0) exit
                call keep()
                line = ""
                first = last + 2
            end do
        end subroutine take
        subroutine keep()
            type(text_line_t), allocatable :: larger(:)
            integer :: k
            if (count == size(kept)) then
                allocate (larger(2 * size(kept)))
                do k = 1, count
                    call move_alloc(kept(k)%text, larger(k)%text)
                end do
                call move_alloc(larger, kept)
            end if
            count = count + 1
            kept(count)%text = line
        end subroutine keep
        subroutine fail(code, why)
            integer, intent(in) :: code
            character(len=*), intent(in) :: why
            ios = code
            message = why
        end subroutine fail
    end subroutine read_text_lines

    !> Position of the first control character of `text` other than a tab or a carriage
    !! return, 0 if none.
    pure integer function control_position(text) result(position)
        character(len=*), intent(in) :: text
        integer :: k, code
        position = 0
        do k = 1, len(text)
            code = iachar(text(k:k))
            if ((code < 32 .and. code /= 9 .and. code /= 13) .or. code == 127) then
                position = k
                return
            end if
        end do
    end function control_position

    !> `text` with every non-printing character made visible, for quoting in a message: a
    !! carriage return as \r, a tab as \t, a line feed as \n, any other control byte
    !! (and DEL) as \xHH. Other bytes are kept.
    pure function printable(text) result(shown)
        character(len=*), intent(in) :: text !! the value to quote
        character(len=:), allocatable :: shown
        character(len=*), parameter :: backslash = achar(92)
        character(len=2) :: hex
        integer :: k, code
        shown = ""
        do k = 1, len(text)
            code = iachar(text(k:k))
            select case (code)
            case (13)
                shown = shown // backslash // "r"
            case (9)
                shown = shown // backslash // "t"
            case (10)
                shown = shown // backslash // "n"
            case (0:8, 11:12, 14:31, 127)
                write (hex, '(z2.2)') code
                shown = shown // backslash // "x" // hex
            case default
                shown = shown // text(k:k)
            end select
        end do
    end function printable

end module holosym_text_file
