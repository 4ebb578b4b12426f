"""What judging rests on: the expected values (live, recorded, replayed), every numeric comparison and
its message, the named mistakes, and the slips generated from the references."""
