!> A small test harness in the spirit of test-drive: named test cases collected into
!! suites, assertions that record the first failure, and a runner that prints one line
!! per test and a final `N passed, M failed`.
module holosym_testing
    use holosym_kinds, only: wp
    use holosym_status_codes, only: real_str, int_str
    implicit none
    private

    public :: test_error_t, test_case_t, test_interface, new_test, run_suite
    public :: check, check_close, check_status_code, skip, split_field, overflow_traps

    !> A failed assertion (or a skipped test): its message.
    type :: test_error_t
        character(len=:), allocatable :: message
        !> True when the test did not run here (see `skip`), rather than failed.
        logical :: skipped = .false.
    end type test_error_t

    abstract interface
        !> A test: leaves `error` unallocated when it passes.
        subroutine test_interface(error)
            import :: test_error_t
            type(test_error_t), allocatable, intent(out) :: error
        end subroutine test_interface
    end interface

    !> A named test case.
    type :: test_case_t
        character(len=:), allocatable :: name
        procedure(test_interface), pointer, nopass :: run => null()
    end type test_case_t

    interface check
        module procedure check_logical
    end interface check

contains

    !> Make a named test case.
    function new_test(name, run) result(test)
        character(len=*), intent(in) :: name       !! test name
        procedure(test_interface) :: run           !! the test
        type(test_case_t) :: test
        test%name = name
        test%run => run
    end function new_test

    !> Fail with `message` unless `condition` holds (first failure wins).
    subroutine check_logical(error, condition, message)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        logical, intent(in) :: condition          !! what must hold
        character(len=*), intent(in) :: message   !! what it means
        if (allocated(error)) return
        if (.not. condition) then
            allocate (error)
            error%message = message
        end if
    end subroutine check_logical

    !> Mark the test as skipped in this build, with the reason (counted apart from passes).
    subroutine skip(error, reason)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        character(len=*), intent(in) :: reason   !! why the test cannot run here
        if (allocated(error)) return
        allocate (error)
        error%message = reason
        error%skipped = .true.
    end subroutine skip

    !> Fail unless |actual - expected| <= abs_tol + rel_tol |expected|.
    subroutine check_close(error, actual, expected, rel_tol, abs_tol, message)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        real(wp), intent(in) :: actual    !! computed value
        real(wp), intent(in) :: expected  !! reference value
        real(wp), intent(in) :: rel_tol   !! relative tolerance
        real(wp), intent(in) :: abs_tol   !! absolute tolerance
        character(len=*), intent(in) :: message !! what is compared
        call check_logical(error, abs(actual - expected) <= abs_tol + rel_tol * abs(expected), &
            message // ": got " // real_str(actual) // ", expected " // real_str(expected))
    end subroutine check_close

    !> Fail unless a status code equals the expected one.
    subroutine check_status_code(error, actual, expected, message)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        integer, intent(in) :: actual     !! code returned
        integer, intent(in) :: expected   !! code required
        character(len=*), intent(in) :: message !! the call
        call check_logical(error, actual == expected, message // ": status " // int_str(actual) &
            // ", expected " // int_str(expected))
    end subroutine check_status_code

    !> True in a build that traps floating-point overflow (-ffpe-trap=overflow, `make
    !! test-trap`): a test, or the part of one, that computes an overflow on purpose cannot
    !! run there (docs/status-codes.md lists them).
    logical function overflow_traps()
        use, intrinsic :: ieee_exceptions, only: ieee_get_halting_mode, ieee_overflow
        call ieee_get_halting_mode(ieee_overflow, overflow_traps)
    end function overflow_traps

    !> Run the tests of a suite whose "suite/name" contains `filter` (all when empty);
    !! print a line per test and add to the counters.
    subroutine run_suite(suite, tests, filter, passed, failed, skipped)
        use, intrinsic :: iso_fortran_env, only: output_unit
        character(len=*), intent(in) :: suite       !! suite name
        type(test_case_t), intent(in) :: tests(:)   !! its tests
        character(len=*), intent(in) :: filter      !! substring selecting tests
        integer, intent(inout) :: passed            !! count of passing tests
        integer, intent(inout) :: failed            !! count of failing tests
        integer, intent(inout) :: skipped           !! count of tests skipped in this build
        type(test_error_t), allocatable :: error
        character(len=:), allocatable :: full_name
        integer :: i
        do i = 1, size(tests)
            full_name = suite // "/" // tests(i)%name
            if (len_trim(filter) > 0 .and. index(full_name, trim(filter)) == 0) cycle
            call tests(i)%run(error)
            if (allocated(error)) then
                if (error%skipped) then
                    skipped = skipped + 1
                    write (output_unit, '(a)') "  skip " // full_name // ": " // error%message
                    cycle
                end if
                failed = failed + 1
                write (output_unit, '(a)') "  FAIL " // full_name // ": " // error%message
            else
                passed = passed + 1
                write (output_unit, '(a)') "  pass " // full_name
            end if
            flush (output_unit)
        end do
    end subroutine run_suite

    !> The k-th field of `line` between `separator` characters ("" if there are fewer
    !! fields): CSV fields with ",", Markdown table cells with "|" (field 1 is then the
    !! text before the first bar).
    pure function split_field(line, k, separator) result(text)
        character(len=*), intent(in) :: line      !! the line
        integer, intent(in) :: k                  !! field number, from 1
        character(len=1), intent(in) :: separator !! field separator
        character(len=:), allocatable :: text
        integer :: first, i, next
        first = 1
        do i = 1, k - 1
            next = index(line(first:), separator)
            if (next == 0) then
                text = ""
                return
            end if
            first = first + next
        end do
        next = index(line(first:), separator)
        if (next == 0) then
            text = line(first:)
        else
            text = line(first:first + next - 2)
        end if
    end function split_field

end module holosym_testing
