!> category: internal module (use holosym)
!! Text files written through the C library's streams (fopen, fwrite, fflush, fclose), so
!! that a write that does not reach the file is seen: a full disk or device (/dev/full),
!! a file-size limit. Fortran units cannot be trusted with that: gfortran 12 reports none
!! of these on write, flush or close (iostat 0), and LLVM flang's runtime stops the
!! program on them even when iostat is given. The files of the ensemble (results, timing
!! log, samples) and of `trajectory_writer` go through `text_file_t`.
!!
!! The C library does not give its error number to Fortran portably, so a failure says
!! which file and which operation, not the system's reason.
module holosym_text_file
    use, intrinsic :: iso_c_binding, only: c_ptr, c_null_ptr, c_associated, c_char, c_int, &
        c_size_t, c_null_char
    implicit none
    private

    public :: text_file_t

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

    interface
        type(c_ptr) function c_fopen(path, mode) bind(C, name="fopen")
            import :: c_ptr, c_char
            character(kind=c_char), intent(in) :: path(*)
            character(kind=c_char), intent(in) :: mode(*)
        end function c_fopen

        integer(c_size_t) function c_fwrite(buffer, size, count, stream) &
            bind(C, name="fwrite")
            import :: c_ptr, c_char, c_size_t
            character(kind=c_char), intent(in) :: buffer(*)
            integer(c_size_t), value :: size, count
            type(c_ptr), value :: stream
        end function c_fwrite

        integer(c_int) function c_fflush(stream) bind(C, name="fflush")
            import :: c_ptr, c_int
            type(c_ptr), value :: stream
        end function c_fflush

        integer(c_int) function c_fclose(stream) bind(C, name="fclose")
            import :: c_ptr, c_int
            type(c_ptr), value :: stream
        end function c_fclose
    end interface

contains

    !> Open `path` for writing: `mode` "new" (refused when the file exists), "replace"
    !! (created or truncated) or "append" (created when missing). False, with `failure`
    !! set, when it cannot be opened. A file still open is closed first.
    logical function text_open(self, path, mode) result(ok)
        class(text_file_t), intent(inout) :: self
        character(len=*), intent(in) :: path !! the file
        character(len=*), intent(in) :: mode !! "new", "replace" or "append"
        character(len=:), allocatable :: c_mode
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
        self%stream = c_fopen(path // c_null_char, c_mode // c_null_char)
        ok = c_associated(self%stream)
        if (.not. ok) then
            if (mode == "new") then
                self%failure = "cannot create '" // path // "' (it may exist already)"
            else
                self%failure = "cannot open '" // path // "' for writing"
            end if
        end if
    end function text_open

    !> Write `text` and a newline (buffered).
    subroutine text_line(self, text)
        class(text_file_t), intent(inout) :: self
        character(len=*), intent(in) :: text !! the line, without its end
        logical :: written
        if (.not. c_associated(self%stream) .or. self%failed()) return
        written = .true.
        if (len(text) > 0) written = c_fwrite(text, 1_c_size_t, int(len(text), c_size_t), &
                                              self%stream) == int(len(text), c_size_t)
        if (written) written = c_fwrite(new_line("a"), 1_c_size_t, 1_c_size_t, &
                                        self%stream) == 1_c_size_t
        if (.not. written) self%failure = "cannot write '" // self%path // &
            "' (a full disk or device, or a file-size limit)"
    end subroutine text_line

    !> Push the buffered lines to the file (a failure is kept).
    subroutine text_flush(self)
        class(text_file_t), intent(inout) :: self
        if (.not. c_associated(self%stream) .or. self%failed()) return
        if (c_fflush(self%stream) /= 0) self%failure = "cannot write '" // self%path // &
            "' (a full disk or device, or a file-size limit)"
    end subroutine text_flush

    !> Flush and close the file; true when every line written reached it.
    logical function text_close(self) result(ok)
        class(text_file_t), intent(inout) :: self
        if (.not. allocated(self%failure)) self%failure = ""
        if (c_associated(self%stream)) then
            call self%flush()
            if (c_fclose(self%stream) /= 0 .and. .not. self%failed()) self%failure = &
                "cannot close '" // self%path // "' (a full disk or device?)"
            self%stream = c_null_ptr
        end if
        ok = .not. self%failed()
    end function text_close

    !> True when a write, flush or close has failed.
    pure logical function text_failed(self)
        class(text_file_t), intent(in) :: self
        text_failed = .false.
        if (allocated(self%failure)) text_failed = len(self%failure) > 0
    end function text_failed

end module holosym_text_file
