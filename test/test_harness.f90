!> Tests of the test suite's own command helpers: arguments reach a command unchanged
!! whatever characters they hold, exit codes and both outputs are captured, and the
!! `holosym` executable is found.
module test_harness
    use holosym_status_codes, only: int_str
    use holosym_testing, only: test_case_t, new_test, test_error_t, check
    use holosym_test_commands, only: command_result_t, run_shell, run_holosym, shell_quote, &
        holosym_executable, file_exists
    implicit none
    private
    public :: harness_tests

contains

    !> The tests of this suite.
    function harness_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("arguments_quoted_for_the_shell", arguments_quoted), &
            new_test("exit_code_and_outputs_captured", outputs_captured), &
            new_test("executable_found", executable_found)]
    end function harness_tests

    !> Words with blanks, quotes, $, ;, *, backslashes and an empty word come back one per
    !! line from printf, exactly.
    subroutine arguments_quoted(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: words(*) = [character(len=24) :: "plain", "two words", &
            "it's", '"double"', "$HOME", "a;b", "*", "back\slash", "", "--h=1/8"]
        type(command_result_t) :: result
        character(len=:), allocatable :: command
        integer :: i
        command = "printf '%s\n'"
        do i = 1, size(words)
            command = command // " " // shell_quote(trim(words(i)))
        end do
        call run_shell(command, result)
        call check(error, result%exit_code == 0 .and. size(result%out) == size(words), &
            "printf: exit " // int_str(result%exit_code) // ", " // int_str(size(result%out)) &
            // " lines")
        if (allocated(error)) return
        do i = 1, size(words)
            call check(error, result%out(i)%text == trim(words(i)), "word " // int_str(i) // &
                ": got '" // result%out(i)%text // "', expected '" // trim(words(i)) // "'")
        end do
    end subroutine arguments_quoted

    !> A command's exit status, standard output and standard error are kept apart.
    subroutine outputs_captured(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        call run_shell("echo out; echo err >&2; exit 3", result)
        call check(error, result%exit_code == 3, "exit 3, got " // int_str(result%exit_code))
        call check(error, size(result%out) == 1 .and. size(result%err) == 1, "one line each")
        if (allocated(error)) return
        call check(error, result%out(1)%text == "out" .and. result%err(1)%text == "err", &
            "out and err apart")
    end subroutine outputs_captured

    !> The executable built next to the test program (or $HOLOSYM_EXE) runs.
    subroutine executable_found(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        call check(error, file_exists(holosym_executable()), "no executable at " // &
            holosym_executable())
        if (allocated(error)) return
        call run_holosym("--help", result)
        call check(error, result%exit_code == 0 .and. size(result%out) > 0, &
            "holosym --help runs")
    end subroutine executable_found

end module test_harness
