"""jostle"""
