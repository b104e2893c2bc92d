!> Progress lines of the long commands (`bench`, `tables`): "k/N" of the units of work,
!! the wall time since the start and an estimate of the time left (the mean time of the
!! finished units times the units left).
module holosym_progress
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp
    use holosym_status_codes, only: int_str
    implicit none
    private

    public :: progress_clock_t

    !> The start of a command's work, for progress lines.
    type :: progress_clock_t
        integer(int64), private :: start = 0
        integer(int64), private :: rate = 1
    contains
        !> Start the clock now.
        procedure :: begin => clock_begin
        !> Write "PREFIX[k/N, E elapsed, about L left] TEXT" to a unit.
        procedure :: report => clock_report
    end type progress_clock_t

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    subroutine clock_begin(self)
        class(progress_clock_t), intent(inout) :: self
        call system_clock(self%start, self%rate)
    end subroutine clock_begin

    !> One progress line. `finished` units of `total` are done (the estimate uses them);
    !! `current` is the unit the line is about (finished + 1 while it runs, or finished).
    !! A subroutine writing in place: no deferred-length result (threads call it).
    subroutine clock_report(self, unit, prefix, current, finished, total, text)
        class(progress_clock_t), intent(in) :: self
        integer, intent(in) :: unit                !! where the line goes
        character(len=*), intent(in) :: prefix     !! e.g. "bench: "
        integer, intent(in) :: current, finished, total
        character(len=*), intent(in) :: text       !! what the line says
        integer(int64) :: now
        real(wp) :: elapsed
        character(len=24) :: elapsed_text, left_text
        call system_clock(now)
        elapsed = real(now - self%start, wp) / real(max(self%rate, 1_int64), wp)
        call duration(elapsed, elapsed_text)
        if (finished > 0 .and. total >= finished) then
            call duration(elapsed / finished * (total - finished), left_text)
            left_text = "about " // trim(left_text) // " left"
        else
            left_text = "time left not known yet"
        end if
        write (unit, '(a)') prefix // "[" // int_str(current) // "/" // int_str(total) // &
            ", " // trim(elapsed_text) // " elapsed, " // trim(left_text) // "] " // text
        flush (unit)
    end subroutine clock_report

    !> Seconds as "42 s", "3 min 05 s" or "2 h 07 min".
    pure subroutine duration(seconds, text)
        real(wp), intent(in) :: seconds
        character(len=*), intent(out) :: text
        integer :: whole
        whole = nint(min(max(seconds, 0.0_wp), 1.0e9_wp))
        if (whole < 60) then
            write (text, '(i0, " s")') whole
        else if (whole < 3600) then
            write (text, '(i0, " min ", i2.2, " s")') whole / 60, mod(whole, 60)
        else
            write (text, '(i0, " h ", i2.2, " min")') whole / 3600, mod(whole, 3600) / 60
        end if
    end subroutine duration

end module holosym_progress

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_progress) holosym_progress_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_progress_app
