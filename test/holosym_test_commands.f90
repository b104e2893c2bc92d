!> Commands for the test suite: the `holosym` executable run with arguments (exit code,
!! standard output and standard error captured), shell commands, text files read line by
!! line, and a scratch directory for their files.
!!
!! The application's modules belong to the executable, not to the library, so the tests
!! drive the command-line tool as a user does. `fpm test` builds the executable into the
!! same build directory as the test program (`build/<compiler_hash>/app/holosym` next to
!! `build/<compiler_hash>/test/holosym_tests`); the environment variable HOLOSYM_EXE names
!! another one. The scratch directory sits next to the test program, so the real128 and
!! real64 builds never share it. Arguments are single-quoted for the shell, so none is
!! ever interpreted by it.
module holosym_test_commands
    implicit none
    private

    public :: text_line_t, command_result_t
    public :: holosym_executable, run_holosym, run_shell, shell_quote, words
    public :: scratch_path, reset_scratch, remove_scratch
    public :: read_lines, write_lines, file_exists, file_sha256, any_line_contains

    !> One line of text.
    type :: text_line_t
        character(len=:), allocatable :: text !! the line, without its end
    end type text_line_t

    !> What a command did.
    type :: command_result_t
        !> The command line as run (for messages).
        character(len=:), allocatable :: command
        !> Exit status of the command; -1 when it could not be run.
        integer :: exit_code = -1
        !> Lines written to standard output.
        type(text_line_t), allocatable :: out(:)
        !> Lines written to standard error.
        type(text_line_t), allocatable :: err(:)
        !> Why the command could not be run ("" when it ran).
        character(len=:), allocatable :: failure
    end type command_result_t

    !> Name of the scratch directory, next to the test program.
    character(len=*), parameter :: scratch_name = "holosym_tests_scratch"

    !> Run the executable with arguments given one per array element (trailing blanks
    !! removed) or as one line split at blanks.
    interface run_holosym
        module procedure run_holosym_args, run_holosym_line
    end interface run_holosym

contains

    !> The text of environment variable `name`, "" when unset.
    function environment(name) result(value)
        character(len=*), intent(in) :: name !! variable name
        character(len=:), allocatable :: value
        integer :: length, stat
        call get_environment_variable(name, length=length, status=stat)
        if (stat /= 0 .or. length == 0) then
            value = ""
            return
        end if
        allocate (character(len=length) :: value)
        call get_environment_variable(name, value, status=stat)
    end function environment

    !> The directory of the test program (from argument 0), "." when it has none.
    function program_directory() result(dir)
        character(len=:), allocatable :: dir
        character(len=:), allocatable :: self
        integer :: length, slash
        call get_command_argument(0, length=length)
        allocate (character(len=length) :: self)
        if (length > 0) call get_command_argument(0, self)
        slash = index(self, "/", back=.true.)
        if (slash > 1) then
            dir = self(:slash - 1)
        else if (slash == 1) then
            dir = "/"
        else
            dir = "."
        end if
    end function program_directory

    !> Path of the `holosym` executable: $HOLOSYM_EXE, else ../app/holosym relative to the
    !! directory of the test program.
    function holosym_executable() result(path)
        character(len=:), allocatable :: path
        character(len=:), allocatable :: dir
        integer :: slash
        path = environment("HOLOSYM_EXE")
        if (len(path) > 0) return
        dir = program_directory()
        slash = index(dir, "/", back=.true.)
        if (slash > 0) then
            path = dir(:slash) // "app/holosym"
        else if (dir == ".") then
            path = "../app/holosym"
        else
            path = "app/holosym"
        end if
    end function holosym_executable

    !> Path of `name` inside the scratch directory (the directory itself for "").
    function scratch_path(name) result(path)
        character(len=*), intent(in) :: name !! file name, "" for the directory
        character(len=:), allocatable :: path
        path = program_directory() // "/" // scratch_name
        if (len(name) > 0) path = path // "/" // name
    end function scratch_path

    !> Remove and recreate the scratch directory; false when it cannot be created.
    logical function reset_scratch() result(ok)
        integer :: exit_code, stat
        call execute_command_line("rm -rf " // shell_quote(scratch_path("")) // " && mkdir -p " &
            // shell_quote(scratch_path("")), wait=.true., exitstat=exit_code, cmdstat=stat)
        ok = stat == 0 .and. exit_code == 0
    end function reset_scratch

    !> Remove the scratch directory.
    subroutine remove_scratch()
        integer :: exit_code, stat
        call execute_command_line("rm -rf " // shell_quote(scratch_path("")), wait=.true., &
                                  exitstat=exit_code, cmdstat=stat)
    end subroutine remove_scratch

    !> `text` as one shell word: in single quotes, each ' written as '\''.
    pure function shell_quote(text) result(quoted)
        character(len=*), intent(in) :: text !! any text
        character(len=:), allocatable :: quoted
        integer :: i
        quoted = "'"
        do i = 1, len(text)
            if (text(i:i) == "'") then
                quoted = quoted // "'\''"
            else
                quoted = quoted // text(i:i)
            end if
        end do
        quoted = quoted // "'"
    end function shell_quote

    !> Run a shell command line (built by the caller from quoted words) in a subshell with
    !! standard input from /dev/null; capture its exit status and both outputs (via scratch
    !! files). The shell itself always succeeds and writes the command's status to a file:
    !! compilers differ in what `execute_command_line` reports for a command that fails
    !! (LLVM flang sets `cmdstat` for any non-zero exit).
    subroutine run_shell(command, result)
        character(len=*), intent(in) :: command     !! the command line
        type(command_result_t), intent(out) :: result !! exit code and output lines
        character(len=:), allocatable :: out_file, err_file, code_file
        type(text_line_t), allocatable :: code(:)
        character(len=256) :: message
        integer :: stat, ios, shell_exit
        out_file = scratch_path("command.out")
        err_file = scratch_path("command.err")
        code_file = scratch_path("command.code")
        result%command = command
        result%failure = ""
        allocate (result%out(0), result%err(0))
        message = ""
        call execute_command_line("( " // command // " ) < /dev/null > " // &
            shell_quote(out_file) // " 2> " // shell_quote(err_file) // "; echo $? > " // &
            shell_quote(code_file), wait=.true., exitstat=shell_exit, cmdstat=stat, &
            cmdmsg=message)
        if (stat /= 0) then
            result%exit_code = -1
            result%failure = "cannot run '" // command // "': " // trim(message)
            return
        end if
        call read_lines(code_file, code, ios)
        if (ios == 0 .and. size(code) == 1) read (code(1)%text, *, iostat=ios) result%exit_code
        if (ios /= 0) then
            result%exit_code = -1
            result%failure = "no exit status of '" // command // "'"
            return
        end if
        call read_lines(out_file, result%out, ios)
        if (ios == 0) call read_lines(err_file, result%err, ios)
        if (ios /= 0) result%failure = "cannot read the output of '" // command // "'"
    end subroutine run_shell

    !> Run the executable with `args(i)` (trailing blanks removed) as its arguments.
    subroutine run_holosym_args(args, result)
        character(len=*), intent(in) :: args(:)       !! the arguments
        type(command_result_t), intent(out) :: result !! exit code and output lines
        character(len=:), allocatable :: exe, command
        integer :: i
        exe = holosym_executable()
        if (.not. file_exists(exe)) then
            result%command = exe
            result%failure = "no holosym executable at '" // exe // "' (build it with " // &
                "fpm build, or set HOLOSYM_EXE)"
            allocate (result%out(0), result%err(0))
            return
        end if
        command = shell_quote(exe)
        do i = 1, size(args)
            command = command // " " // shell_quote(trim(args(i)))
        end do
        call run_shell(command, result)
    end subroutine run_holosym_args

    !> Run the executable with the blank-separated words of `line` as its arguments.
    subroutine run_holosym_line(line, result)
        character(len=*), intent(in) :: line          !! arguments separated by blanks
        type(command_result_t), intent(out) :: result !! exit code and output lines
        character(len=len(line)), allocatable :: words(:)
        integer :: first, last
        allocate (words(0))
        last = 0
        do
            first = verify(line(last + 1:), " ")
            if (first == 0) exit
            first = last + first
            last = index(line(first:), " ")
            if (last == 0) then
                last = len(line) + 1
            else
                last = first + last - 1
            end if
            words = [character(len=len(line)) :: words, line(first:last - 1)]
            if (last >= len(line)) exit
        end do
        call run_holosym_args(words, result)
    end subroutine run_holosym_line

    !> Up to twelve words as an argument list for `run_holosym` (any lengths; a word's
    !! trailing blanks are not kept).
    function words(w1, w2, w3, w4, w5, w6, w7, w8, w9, w10, w11, w12) result(list)
        character(len=*), intent(in) :: w1                       !! first word
        character(len=*), intent(in), optional :: w2, w3, w4, w5, w6, w7, w8 !! more words
        character(len=*), intent(in), optional :: w9, w10, w11, w12 !! more words
        character(len=:), allocatable :: list(:)
        integer :: length, count
        length = len(w1)
        count = 1
        call measure(w2)
        call measure(w3)
        call measure(w4)
        call measure(w5)
        call measure(w6)
        call measure(w7)
        call measure(w8)
        call measure(w9)
        call measure(w10)
        call measure(w11)
        call measure(w12)
        allocate (character(len=length) :: list(count))
        list(1) = w1
        count = 1
        call add(w2)
        call add(w3)
        call add(w4)
        call add(w5)
        call add(w6)
        call add(w7)
        call add(w8)
        call add(w9)
        call add(w10)
        call add(w11)
        call add(w12)
    contains
        subroutine measure(word)
            character(len=*), intent(in), optional :: word
            if (.not. present(word)) return
            length = max(length, len(word))
            count = count + 1
        end subroutine measure
        subroutine add(word)
            character(len=*), intent(in), optional :: word
            if (.not. present(word)) return
            count = count + 1
            list(count) = word
        end subroutine add
    end function words

    !> Every line of a text file, of any length; `ios` /= 0 when it cannot be read.
    subroutine read_lines(path, lines, ios)
        character(len=*), intent(in) :: path                   !! the file
        type(text_line_t), allocatable, intent(out) :: lines(:) !! its lines
        integer, intent(out) :: ios                            !! 0 on success
        character(len=4096) :: chunk
        character(len=:), allocatable :: line
        integer :: unit, got
        allocate (lines(0))
        open (newunit=unit, file=path, status="old", action="read", iostat=ios)
        if (ios /= 0) return
        do
            line = ""
            do
                read (unit, '(a)', advance="no", iostat=ios, size=got) chunk
                line = line // chunk(:got)
                if (ios /= 0) exit
            end do
            if (is_iostat_end(ios)) exit
            if (.not. is_iostat_eor(ios)) then
                close (unit)
                return
            end if
            lines = [lines, text_line_t(line)]
        end do
        ios = 0
        close (unit)
    end subroutine read_lines

    !> Write lines (trailing blanks removed) to a file, replacing it.
    subroutine write_lines(path, lines)
        character(len=*), intent(in) :: path     !! the file
        character(len=*), intent(in) :: lines(:) !! its lines
        integer :: unit, i
        open (newunit=unit, file=path, status="replace", action="write")
        do i = 1, size(lines)
            write (unit, '(a)') trim(lines(i))
        end do
        close (unit)
    end subroutine write_lines

    !> Whether a file exists.
    logical function file_exists(path)
        character(len=*), intent(in) :: path !! the file
        inquire (file=path, exist=file_exists)
    end function file_exists

    !> SHA-256 of a file as 64 hex digits, from `sha256sum`; "" when it cannot be computed.
    function file_sha256(path) result(digest)
        character(len=*), intent(in) :: path !! the file
        character(len=:), allocatable :: digest
        type(command_result_t) :: result
        digest = ""
        call run_shell("sha256sum " // shell_quote(path), result)
        if (result%exit_code /= 0 .or. size(result%out) /= 1) return
        if (len(result%out(1)%text) < 64) return
        digest = result%out(1)%text(1:64)
        if (verify(digest, "0123456789abcdef") /= 0) digest = ""
    end function file_sha256

    !> Whether any of the lines contains `fragment`.
    pure logical function any_line_contains(lines, fragment)
        type(text_line_t), intent(in) :: lines(:) !! the lines
        character(len=*), intent(in) :: fragment  !! text to find
        integer :: i
        any_line_contains = .false.
        do i = 1, size(lines)
            if (index(lines(i)%text, fragment) > 0) then
                any_line_contains = .true.
                return
            end if
        end do
    end function any_line_contains

end module holosym_test_commands
