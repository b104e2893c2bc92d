!> Tests of `lyapunov_spectrum`: on the spherical pendulum (integrable) the exponents decay
!! like log(t)/t and MEGNO tends to 2; on the double pendulum released at 2 and 2.5 rad
!! (chaotic) one exponent is positive, its partner negative, the other two near zero, MEGNO
!! far above 2, and h and h/2 agree while their trajectories do; bad input refused.
module test_lyapunov
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, real_str, int_str, HOLOSYM_SUCCESS, &
        HOLOSYM_INVALID_STEP_COUNT, HOLOSYM_NOT_INITIALIZED
    use holosym_models, only: spherical_pendulum
    use holosym_model_chain, only: pendulum_chain
    use holosym_integrator, only: constrained_integrator
    use holosym_lyapunov, only: lyapunov_spectrum, lyapunov_result_t, lyapunov_tracker_t
    use holosym_test_commands, only: command_result_t, run_holosym, read_lines, scratch_path, &
        text_line_t, any_line_contains
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_status_code, &
        split_field
    implicit none
    private
    public :: lyapunov_tests

contains

    !> The tests of this suite.
    function lyapunov_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("spherical_pendulum_regular", regular), &
            new_test("double_pendulum_chaotic", chaotic), &
            new_test("a_run_in_pieces_is_one_run", pieces), &
            new_test("bad_input_refused", refusals), &
            new_test("cli_lyapunov_model_file", cli_model), &
            new_test("cli_lyapunov_refusals", cli_refusals) &
        ]
    end function lyapunov_tests

    !> Spherical pendulum, (4, 3, 5), h = 1/8 to T = 50 and 200: the largest exponent is
    !! about log(T)/T (a tangent vector grows linearly), the spectrum pairs (lambda_i +
    !! lambda_(5-i) = O(1/T)) and MEGNO approaches 2.
    subroutine regular(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(lyapunov_result_t) :: runs(2)
        integer :: k, i
        real(wp) :: law
        do k = 1, 2
            call sphere_run(0.125_wp, 400 * 4**(k - 1), runs(k), error)
            if (allocated(error)) return
            associate (r => runs(k))
                law = r%exponents(1) * r%time / log(r%time)
                call check(error, law >= 0.3_wp .and. law <= 1.5_wp, "T = " // &
                    real_str(r%time) // ": largest exponent " // real_str(r%exponents(1)) // &
                    " is " // real_str(law) // " log(T)/T")
                if (allocated(error)) return
                do i = 1, 2
                    call check(error, r%time * abs(r%exponents(i) + r%exponents(5 - i)) <= 2, &
                        "pair " // int_str(i) // " at T = " // real_str(r%time) // ": " // &
                        real_str(r%exponents(i)) // ", " // real_str(r%exponents(5 - i)))
                    if (allocated(error)) return
                end do
            end associate
        end do
        call check(error, abs(runs(2)%megno - 2) <= 0.25_wp .and. &
            abs(runs(2)%megno - 2) < abs(runs(1)%megno - 2), "MEGNO " // &
            real_str(runs(1)%megno) // " at T = 50, " // real_str(runs(2)%megno) // " at 200")
    end subroutine regular

    !> Double pendulum (unit masses and rods) from rest at 2 and 2.5 rad, (4, 3, 5), to
    !! T = 25 with h = 1/16 and 1/32 (within the time the two trajectories stay together):
    !! a positive exponent and its negative partner, two exponents of order 1/T, MEGNO far
    !! above 2, and the same largest exponent from h and h/2 to 1e-3.
    subroutine chaotic(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(pendulum_chain), target :: sys
        type(constrained_integrator) :: integ
        type(lyapunov_result_t) :: runs(2)
        type(holosym_status_t) :: status
        real(wp) :: q(4), p(4)
        integer :: k
        sys = pendulum_chain(2)
        do k = 1, 2
            q = [sin(2.0_wp), -cos(2.0_wp), sin(2.0_wp) + sin(2.5_wp), &
                 -cos(2.0_wp) - cos(2.5_wp)]
            p = 0
            call integ%init(sys, 4, 3, 5, status)
            if (status%ok()) call lyapunov_spectrum(integ, sys, q, p, 0.0625_wp / k, 400 * k, &
                                                    runs(k), status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "h = 1/" // &
                int_str(16 * k))
            if (allocated(error)) return
            associate (e => runs(k)%exponents, t => runs(k)%time)
                call check(error, e(1) > 0.3_wp .and. t * abs(e(1) + e(4)) <= 2 .and. &
                    t * max(abs(e(2)), abs(e(3))) <= 3, "spectrum " // real_str(e(1)) // &
                    ", " // real_str(e(2)) // ", " // real_str(e(3)) // ", " // real_str(e(4)))
                if (allocated(error)) return
            end associate
            call check(error, runs(k)%megno > 4, "MEGNO " // real_str(runs(k)%megno))
            if (allocated(error)) return
        end do
        call check(error, abs(runs(1)%exponents(1) - runs(2)%exponents(1)) <= &
            1.0e-3_wp * runs(2)%exponents(1), "h and h/2: " // real_str(runs(1)%exponents(1)) &
            // ", " // real_str(runs(2)%exponents(1)))
    end subroutine chaotic

    !> A tracker advanced 100 + 60 + 0 + 40 steps gives the spectrum and MEGNO of
    !! `lyapunov_spectrum` over 200 steps, bit for bit; `advance` before `start` refused.
    subroutine pieces(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: sys
        type(constrained_integrator) :: integ
        type(lyapunov_tracker_t) :: tracker
        type(lyapunov_result_t) :: whole, parts
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3)
        integer :: k
        integer, parameter :: chunks(4) = [100, 60, 0, 40]
        sys = spherical_pendulum()
        call integ%init(sys, 4, 3, 5, status)
        call tracker%advance(integ, sys, q, p, 0.125_wp, 1, status)
        call check_status_code(error, status%code, HOLOSYM_NOT_INITIALIZED, "advance first")
        if (allocated(error)) return
        call sys%initial_state(q, p)
        call lyapunov_spectrum(integ, sys, q, p, 0.125_wp, 200, whole, status)
        call sys%initial_state(q, p)
        if (status%ok()) call tracker%start(sys, q, p, status)
        do k = 1, size(chunks)
            if (status%ok()) call tracker%advance(integ, sys, q, p, 0.125_wp, chunks(k), status)
        end do
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "runs")
        if (allocated(error)) return
        parts = tracker%result()
        call check(error, all(parts%exponents == whole%exponents) .and. &
            parts%megno == whole%megno .and. parts%steps == 200, "pieces differ: " // &
            real_str(maxval(abs(parts%exponents - whole%exponents))))
    end subroutine pieces

    !> No steps: refused. A step too large: the failure's code, nothing measured, the
    !! state unchanged.
    subroutine refusals(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum), target :: sys
        type(constrained_integrator) :: integ
        type(lyapunov_result_t) :: result
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3), q0(3), p0(3)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        q0 = q
        p0 = p
        call integ%init(sys, 4, 3, 5, status)
        call lyapunov_spectrum(integ, sys, q, p, 0.125_wp, 0, result, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_STEP_COUNT, "0 steps")
        if (allocated(error)) return
        call lyapunov_spectrum(integ, sys, q, p, 50.0_wp, 10, result, status)
        call check(error, .not. status%ok() .and. result%steps == 0 .and. &
            .not. allocated(result%exponents) .and. all(q == q0) .and. all(p == p0), &
            "h = 50: status " // int_str(status%code) // ", " // int_str(result%steps) // &
            " steps")
    end subroutine refusals

    !> `holosym lyapunov` on the double pendulum's model file set to the chaotic start of
    !! `double_pendulum_chaotic`: the CSV's header, a row every 150 steps and after the
    !! last, and the same spectrum as the library on the built-in twin (to the twins'
    !! round-off, grown by the chaos, e^(0.5 T) = 3e5 at T = 25: 1e-20 in real128; in the
    !! real64 build the command may be either build's, so 1e6 epsilon).
    subroutine cli_model(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: a
        type(text_line_t), allocatable :: rows(:)
        type(pendulum_chain), target :: sys
        type(constrained_integrator) :: integ
        type(lyapunov_result_t) :: library
        type(holosym_status_t) :: status
        character(len=:), allocatable :: file, field
        real(wp) :: values(6), q(4), p(4)
        real(wp), parameter :: agreement = max(1.0e-20_wp, 1.0e6_wp * epsilon(1.0_wp))
        integer :: ios, i
        file = scratch_path("lyapunov.csv")
        call run_holosym([character(len=256) :: "lyapunov", "--model", &
            "example/models/double_pendulum.hsm", "--set", "m2=1", "--set", "l2=1", "--set", &
            "theta1=2", "--set", "theta2=2.5", "--M", "4", "--h", "1/16", "--T", "25", &
            "--every", "150", "--output", file], a)
        call check(error, len(a%failure) == 0 .and. a%exit_code == 0, "exit " // &
            int_str(a%exit_code) // " " // a%failure)
        if (allocated(error)) return
        call read_lines(file, rows, ios)
        call check(error, ios == 0 .and. size(rows) == 4, int_str(size(rows)) // " lines")
        if (allocated(error)) return
        call check(error, rows(1)%text == "t,lambda1,lambda2,lambda3,lambda4,megno", &
            rows(1)%text)
        if (allocated(error)) return
        do i = 1, 6
            field = split_field(rows(4)%text, i, ",")
            read (field, *, iostat=ios) values(i)
            if (ios /= 0) exit
        end do
        sys = pendulum_chain(2)
        q = [sin(2.0_wp), -cos(2.0_wp), sin(2.0_wp) + sin(2.5_wp), -cos(2.0_wp) - cos(2.5_wp)]
        p = 0
        call integ%init(sys, 4, 3, 5, status)
        if (status%ok()) call lyapunov_spectrum(integ, sys, q, p, 0.0625_wp, 400, library, &
                                                status)
        call check(error, ios == 0 .and. status%ok() .and. values(1) == 25 .and. &
            maxval(abs(values(2:5) - library%exponents)) <= agreement .and. &
            abs(values(6) - library%megno) <= agreement .and. &
            any_line_contains(a%err, "MEGNO"), "last row " // rows(4)%text)
    end subroutine cli_model

    !> T = 0, --every 0, an unknown option: exit 2 naming the option.
    subroutine cli_refusals(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: a
        call run_holosym("lyapunov --T 0", a)
        call check(error, a%exit_code == 2 .and. any_line_contains(a%err, "options --T " // &
            "and --h"), "T = 0: exit " // int_str(a%exit_code))
        if (allocated(error)) return
        call run_holosym("lyapunov --every 0", a)
        call check(error, a%exit_code == 2 .and. any_line_contains(a%err, "--every"), &
            "--every 0: exit " // int_str(a%exit_code))
        if (allocated(error)) return
        call run_holosym("lyapunov --states x.csv", a)
        call check(error, a%exit_code == 2 .and. any_line_contains(a%err, &
            "unknown option '--states'"), "--states: exit " // int_str(a%exit_code))
    end subroutine cli_refusals

    subroutine sphere_run(h, steps, result, error)
        real(wp), intent(in) :: h
        integer, intent(in) :: steps
        type(lyapunov_result_t), intent(out) :: result
        type(test_error_t), allocatable, intent(inout) :: error
        type(spherical_pendulum), target :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        call integ%init(sys, 4, 3, 5, status)
        if (status%ok()) call lyapunov_spectrum(integ, sys, q, p, h, steps, result, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "spherical pendulum")
    end subroutine sphere_run

end module test_lyapunov
