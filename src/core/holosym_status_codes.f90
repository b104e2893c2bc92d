!> category: internal module (use holosym)
!! Status codes and the status object returned by every fallible public procedure.
!!
!! Convention: 0 is success, a negative code is invalid input (or a user abort),
!! a positive code is a numerical failure. Every public entry point takes an optional
!! `type(holosym_status_t), intent(out) :: status`; when it is absent and the call fails,
!! the program stops with the message (`error stop`). docs/status-codes.md lists every
!! code with where it is returned, and every limit.
module holosym_status_codes
    ! The finiteness tests are IEEE classifications, which never raise an exception (an
    ! ordered comparison with a NaN raises 'invalid', which traps under -ffpe-trap=invalid).
    ! Used here, at module level, they add no per-call floating-point state handling.
    use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_is_nan
    use holosym_kinds, only: wp
    implicit none
    private

    !> Significant digits of `real_str`.
    integer, parameter :: short_digits = 4

    public :: holosym_status_t, set_status, status_code_name, code_name_field, int_str, &
        int_len, real_str, real_field, is_finite, is_nan, is_status_code, is_system_fault, &
        append_numbered

    !> Success.
    integer, parameter, public :: HOLOSYM_SUCCESS = 0
    !> M, N or G outside 1 <= M <= max_order_m, 0 <= N <= max_order_n,
    !! 1 <= G <= max_gauss_points, or G < N + 1, which gives a singular Newton Jacobian for
    !! every system.
    integer, parameter, public :: HOLOSYM_INVALID_ORDER = -1
    !> Problem dimensions invalid: n < 1, m < 0 or m >= n, or sizes of the step's
    !! equations that overflow the default integer.
    integer, parameter, public :: HOLOSYM_INVALID_DIMENSION = -2
    !> An array argument does not have the size that n, m or the scheme require.
    integer, parameter, public :: HOLOSYM_SIZE_MISMATCH = -3
    !> Step size h <= 0 or not finite.
    integer, parameter, public :: HOLOSYM_INVALID_STEP_SIZE = -4
    !> Step count < 0.
    integer, parameter, public :: HOLOSYM_INVALID_STEP_COUNT = -5
    !> Initial state off the constraint manifold (|phi| or |Phi H_p| above tolerance).
    integer, parameter, public :: HOLOSYM_OFF_MANIFOLD = -6
    !> The user's observer asked to stop the run.
    integer, parameter, public :: HOLOSYM_USER_ABORT = -7
    !> The integrator was used before a successful `init`.
    integer, parameter, public :: HOLOSYM_NOT_INITIALIZED = -8
    !> Any other invalid argument (a non-finite input value, tau outside [0,1], ...).
    integer, parameter, public :: HOLOSYM_INVALID_ARGUMENT = -9
    !> A model file (or model text) refused: a syntax or meaning error, or an initial
    !! state where the model cannot be evaluated; the message gives file:line:column.
    integer, parameter, public :: HOLOSYM_INVALID_MODEL = -10
    !> A system whose procedures or declarations disagree with each other (`check_system`:
    !! a gradient against differences of H, a declared mass against dh_dp, a declared
    !! sparsity against the whole Jacobian, ...); the message names them and the entry.
    integer, parameter, public :: HOLOSYM_INCONSISTENT_SYSTEM = -11
    !> The Newton Jacobian (or a matrix given to the LU) is singular to working precision.
    integer, parameter, public :: HOLOSYM_SINGULAR_MATRIX = 1
    !> Newton's method did not converge within its iteration limit.
    integer, parameter, public :: HOLOSYM_NEWTON_NOT_CONVERGED = 2
    !> Newton's method diverged (corrections kept growing); the step is likely too large.
    integer, parameter, public :: HOLOSYM_NEWTON_DIVERGED = 3
    !> A user procedure (H, its gradients, phi, Phi, ...) returned NaN or Inf.
    integer, parameter, public :: HOLOSYM_NONFINITE_VALUE = 4
    !> The constraint Jacobian Phi is rank deficient at the state, or becomes so within
    !! the step (at a displacement node of the failing Newton iterate).
    integer, parameter, public :: HOLOSYM_RANK_DEFICIENT_CONSTRAINTS = 5
    !> The step is too large: Newton converged to a root that is not the continuation of
    !! the flow, or h does not resolve the motion (the step changed the energy by more than
    !! 1e-3 relative and lies more than 1e-2 from two half steps), or the step's equations
    !! overflow or are singular at this h only (they are not at a smaller h). Reduce h.
    integer, parameter, public :: HOLOSYM_STEP_TOO_LARGE = 6
    !> h is below the resolution of the state: the round-off of q, epsilon |q|, divided by
    !! h exceeds Newton's stagnation level in the momenta, so the step's equations cannot
    !! be solved; the message gives the limit for the state. Increase h.
    integer, parameter, public :: HOLOSYM_STEP_TOO_SMALL = 7
    !> A procedure of the system refused the point it was called at (`refuse`; a C
    !! callback's non-zero return): the point lies outside the domain where the system
    !! can be evaluated. The message gives the system's reason. Nothing is changed.
    integer, parameter, public :: HOLOSYM_OUTSIDE_DOMAIN = 8

    !> One status code: its value, its constant's name and its short name.
    type, public :: status_code_entry_t
        integer :: code = 0
        character(len=40) :: constant = ""  !! e.g. "HOLOSYM_SINGULAR_MATRIX"
        character(len=40) :: name = ""      !! e.g. "singular matrix"
    end type status_code_entry_t

    !> Every status code: the one table the short names (`status_code_name`), the C
    !! header (include/holosym.h) and docs/status-codes.md follow (a test compares them).
    type(status_code_entry_t), parameter, public :: status_code_table(20) = [ &
        status_code_entry_t(HOLOSYM_SUCCESS, "HOLOSYM_SUCCESS", "success"), &
        status_code_entry_t(HOLOSYM_INVALID_ORDER, "HOLOSYM_INVALID_ORDER", &
                            "invalid order parameters"), &
        status_code_entry_t(HOLOSYM_INVALID_DIMENSION, "HOLOSYM_INVALID_DIMENSION", &
                            "invalid problem dimensions"), &
        status_code_entry_t(HOLOSYM_SIZE_MISMATCH, "HOLOSYM_SIZE_MISMATCH", &
                            "array size mismatch"), &
        status_code_entry_t(HOLOSYM_INVALID_STEP_SIZE, "HOLOSYM_INVALID_STEP_SIZE", &
                            "invalid step size"), &
        status_code_entry_t(HOLOSYM_INVALID_STEP_COUNT, "HOLOSYM_INVALID_STEP_COUNT", &
                            "invalid step count"), &
        status_code_entry_t(HOLOSYM_OFF_MANIFOLD, "HOLOSYM_OFF_MANIFOLD", &
                            "state off the constraint manifold"), &
        status_code_entry_t(HOLOSYM_USER_ABORT, "HOLOSYM_USER_ABORT", &
                            "stopped by the observer"), &
        status_code_entry_t(HOLOSYM_NOT_INITIALIZED, "HOLOSYM_NOT_INITIALIZED", &
                            "integrator not initialized"), &
        status_code_entry_t(HOLOSYM_INVALID_ARGUMENT, "HOLOSYM_INVALID_ARGUMENT", &
                            "invalid argument"), &
        status_code_entry_t(HOLOSYM_INVALID_MODEL, "HOLOSYM_INVALID_MODEL", "invalid model"), &
        status_code_entry_t(HOLOSYM_INCONSISTENT_SYSTEM, "HOLOSYM_INCONSISTENT_SYSTEM", &
                            "inconsistent system"), &
        status_code_entry_t(HOLOSYM_SINGULAR_MATRIX, "HOLOSYM_SINGULAR_MATRIX", &
                            "singular matrix"), &
        status_code_entry_t(HOLOSYM_NEWTON_NOT_CONVERGED, "HOLOSYM_NEWTON_NOT_CONVERGED", &
                            "Newton not converged"), &
        status_code_entry_t(HOLOSYM_NEWTON_DIVERGED, "HOLOSYM_NEWTON_DIVERGED", &
                            "Newton diverged"), &
        status_code_entry_t(HOLOSYM_NONFINITE_VALUE, "HOLOSYM_NONFINITE_VALUE", &
                            "non-finite value"), &
        status_code_entry_t(HOLOSYM_RANK_DEFICIENT_CONSTRAINTS, &
                            "HOLOSYM_RANK_DEFICIENT_CONSTRAINTS", &
                            "rank-deficient constraint Jacobian"), &
        status_code_entry_t(HOLOSYM_STEP_TOO_LARGE, "HOLOSYM_STEP_TOO_LARGE", &
                            "step too large"), &
        status_code_entry_t(HOLOSYM_STEP_TOO_SMALL, "HOLOSYM_STEP_TOO_SMALL", &
                            "step below the resolution of the state"), &
        status_code_entry_t(HOLOSYM_OUTSIDE_DOMAIN, "HOLOSYM_OUTSIDE_DOMAIN", &
                            "point outside the system's domain")]

    !> Outcome of a call: a code (see the HOLOSYM_* constants) and a message.
    type :: holosym_status_t
        !> 0 on success, < 0 invalid input, > 0 numerical failure.
        integer :: code = HOLOSYM_SUCCESS
        !> Human-readable description; empty on success.
        character(len=:), allocatable :: message
    contains
        !> True when the call succeeded.
        procedure :: ok => status_ok
    end type holosym_status_t

contains

    !> True when `self%code` is `HOLOSYM_SUCCESS`.
    elemental logical function status_ok(self)
        class(holosym_status_t), intent(in) :: self !! status to test
        status_ok = self%code == HOLOSYM_SUCCESS
    end function status_ok

    !> Record an outcome: fill `status` when present; otherwise stop on failure.
    pure subroutine set_status(status, code, message)
        type(holosym_status_t), intent(inout), optional :: status !! caller's status, if any
        integer, intent(in) :: code             !! HOLOSYM_* code
        character(len=*), intent(in) :: message !! description, naming the offending value
        character(len=:), allocatable :: text
        if (present(status)) then
            status%code = code
            status%message = message
        else if (code /= HOLOSYM_SUCCESS) then
            text = "holosym: " // status_code_name(code) // ": " // message
            error stop text
        end if
    end subroutine set_status

    !> `status_code_name(code)` in 40 characters ("unknown status" for a code not in
    !! `status_code_table`).
    pure function code_name_field(code) result(name)
        integer, intent(in) :: code !! HOLOSYM_* code
        character(len=40) :: name
        integer :: k
        name = "unknown status"
        do k = 1, size(status_code_table)
            if (status_code_table(k)%code == code) name = status_code_table(k)%name
        end do
    end function code_name_field

    !> Whether `code` is one of the library's status codes (a row of `status_code_table`).
    elemental logical function is_status_code(code)
        integer, intent(in) :: code !! a code
        is_status_code = any(status_code_table%code == code)
    end function is_status_code

    !> Whether a failure with `code` is the system's (a procedure returned NaN or Inf, or
    !! refused the point): retrying the step from another guess or with other factors
    !! would call the system at the same points, so the step fails at once.
    elemental logical function is_system_fault(code)
        integer, intent(in) :: code !! HOLOSYM_* code
        is_system_fault = code == HOLOSYM_NONFINITE_VALUE .or. code == HOLOSYM_OUTSIDE_DOMAIN
    end function is_system_fault

    !> Short symbolic name of a status code, e.g. "singular matrix".
    pure function status_code_name(code) result(name)
        integer, intent(in) :: code !! HOLOSYM_* code
        character(len=len_trim(code_name_field(code))) :: name
        name = code_name_field(code)
    end function status_code_name

    !> True when `value` is neither NaN nor infinite (never raises an IEEE exception).
    elemental logical function is_finite(value)
        real(wp), intent(in) :: value !! value to test
        is_finite = ieee_is_finite(value)
    end function is_finite

    !> True when `value` is a NaN (never raises an IEEE exception).
    elemental logical function is_nan(value)
        real(wp), intent(in) :: value !! value to test
        is_nan = ieee_is_nan(value)
    end function is_nan

    !> Length of `int_str(value)`.
    pure integer function int_len(value)
        integer, intent(in) :: value !! integer to format
        character(len=24) :: buffer
        write (buffer, '(i0)') value
        int_len = len_trim(buffer)
    end function int_len

    !> `real_str(value)` left-adjusted in 48 characters.
    pure function real_field(value) result(buffer)
        real(wp), intent(in) :: value !! value to format
        character(len=48) :: buffer
        ! Non-finite values spelled alike by every compiler.
        if (value /= value) then
            buffer = "NaN"
        else if (abs(value) > huge(value)) then
            buffer = merge("Infinity ", "-Infinity", value > 0)
        else
            ! A four-digit exponent field: real128 exponents reach 4932.
            write (buffer, '(es16.5e4)') value
            buffer = adjustl(buffer)
        end if
    end function real_field

    !> Decimal text of an integer, for messages.
    !!
    !! The text functions of this module (`status_code_name`, `int_str`, `real_str`) have
    !! results of a computed length, never a deferred one: gfortran (12) keeps the length
    !! of a deferred-length function result in a static variable at each call site, so
    !! that two threads building a message at the same place corrupt each other's text
    !! and the heap.
    pure function int_str(value) result(text)
        integer, intent(in) :: value !! integer to format
        character(len=int_len(value)) :: text
        write (text, '(i0)') value
    end function int_str

    !> Append "q1,q2,...,qn" to `text`: `prefix` numbered 1..count, joined by
    !! `separator` (nothing for count 0); the names of CSV columns and model variables.
    pure subroutine append_numbered(text, prefix, count, separator)
        character(len=:), allocatable, intent(inout) :: text !! grows by the names
        character(len=*), intent(in) :: prefix    !! e.g. "q"
        integer, intent(in) :: count              !! how many
        character(len=*), intent(in) :: separator !! e.g. ","
        integer :: i
        if (.not. allocated(text)) text = ""
        do i = 1, count
            if (i > 1) text = text // separator
            text = text // prefix // int_str(i)
        end do
    end subroutine append_numbered

    !> `real_str(value)` in 48 characters.
    pure function short_field(value) result(buffer)
        real(wp), intent(in) :: value !! value to format
        character(len=48) :: buffer
        character(len=48) :: scientific
        character(len=short_digits) :: digits
        character(len=:), allocatable :: sign, fraction
        integer :: e, exponent, used
        if (.not. is_finite(value)) then
            buffer = real_field(value)
            return
        else if (value == 0) then
            buffer = "0"
            return
        end if
        write (scientific, '(es48.' // achar(iachar("0") + short_digits - 1) // 'e4)') abs(value)
        scientific = adjustl(scientific)
        e = index(scientific, "E")
        read (scientific(e + 1:), *) exponent
        digits = scientific(1:1) // scientific(3:e - 1)
        used = len_trim(digits)
        do while (used > 1 .and. digits(used:used) == "0")
            used = used - 1
        end do
        sign = merge("-", " ", value < 0)
        sign = trim(sign)
        if (exponent >= -4 .and. exponent < short_digits) then
            if (exponent >= 0) then
                fraction = ""
                if (used > exponent + 1) fraction = "." // digits(exponent + 2:used)
                buffer = sign // digits(1:min(used, exponent + 1)) // &
                    repeat("0", max(0, exponent + 1 - used)) // fraction
            else
                buffer = sign // "0." // repeat("0", -exponent - 1) // digits(1:used)
            end if
        else
            fraction = ".0"
            if (used > 1) fraction = "." // digits(2:used)
            buffer = sign // digits(1:1) // fraction // "e" // merge("-", "+", exponent < 0) // &
                repeat("0", merge(1, 0, abs(exponent) < 10)) // int_str(abs(exponent))
        end if
    end function short_field

    !> Short text of a real (any kind converted to wp) for people: messages, progress and
    !! summaries. `short_digits` significant digits, trailing zeros dropped; plain from
    !! 1e-4 to below 1e4 ("0.0625", "120", "0.3333"), else scientific with a lowercase e and
    !! a two-digit exponent at least ("1.0e-10", "6.92e-24", "1.5e+30", "1.0e-4932"); "0",
    !! "NaN", "Infinity", "-Infinity". Files keep full digits (their own formats).
    pure function real_str(value) result(text)
        real(wp), intent(in) :: value !! value to format
        character(len=len_trim(short_field(value))) :: text
        text = short_field(value)
    end function real_str

end module holosym_status_codes
